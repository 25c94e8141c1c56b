"""40 MVAr synchronous condenser: subtransient dq model (5th order), swing equation, SEXS AVR.

p.u. on the condenser rating; the network sees E'' behind (ra + j x''), x''q = x''d (see
network.py).  Machine frame (Sauer-Pai): V_net = (v_d + j v_q) e^{j(delta - pi/2)}, so
E''_net = (e''_q - j e''_d) e^{j delta}.

State x = [delta (rad), omega (p.u.), e'_q, e''_q, e''_d, x_ll (SEXS lead-lag), E_fd]::

    T'd0  de'_q/dt  = E_fd - e'_q - (x_d - x'_d) i_d
    T''d0 de''_q/dt = e'_q - e''_q - (x'_d - x''_d) i_d
    T''q0 de''_d/dt = -e''_d + (x_q - x''_q) i_q          (x'_q = x_q: no q-axis transient winding)
    2H    domega/dt = T_m - T_e - D (omega - 1),  T_m = 0,  T_e = e''_d i_d + e''_q i_q
          ddelta/dt = OMEGA0 (omega - 1)
    SEXS: u = V_ref - V_reg - m_q Q;  T_B dx_ll/dt = u - x_ll;  y = (T_A/T_B) u + (1 - T_A/T_B) x_ll
          T_E dE_fd/dt = K y - E_fd,  E_fd clamped to [E_min, E_max] (non-windup)

Simplifications: the (x'_d - x''_d)/(x'_d - x_l)^2 coupling terms of the full 6th-order model and
saturation are neglected; stator transients are neglected with the quasi-static network (with the
dynamic-phasor network the stator current is that of its subtransient RL branch: dynamic_network.py).
"""

from __future__ import annotations

import cmath

import numpy as np

from plant.params import CondenserParams
from sdvisc.vocabulary import OMEGA0

DELTA, OMEGA, EQ1, EQ2, ED2, XLL, EFD = range(7)
NX = 7


class Condenser:
    def __init__(self, params: CondenserParams):
        self.p = params
        self.v_ref = 1.0
        self.z2 = complex(params.ra, params.xd2)

    def e_net(self, x) -> complex:
        return complex(x[EQ2].real, -x[ED2].real) * cmath.exp(1j * x[DELTA].real)

    def current(self, x, v_term: complex) -> complex:
        """Stator current on the SC base, out of the machine, network frame."""
        return (self.e_net(x) - v_term) / self.z2

    def flux_emf(self, x, i_net: complex) -> complex:
        """The rotor's transformer EMF -(1/ω0) d(e''_d + j e''_q)/dt e^{jδ} in the network frame, at
        the stator current ``i_net`` (SC base, network frame).

        Needed only with the stator's transients modelled (the dynamic-phasor network): E'' behind a
        dynamic L'' without it leaves out the dψ''/dt of the stator's voltage equation, and the
        stator's own mode (the DC offset, at ω0 in the rotating frame) is then undamped or growing
        (tests/unit/test_dynamic_network.py checks it decays); with the stator quasi-static it is
        neglected with the other dψ/dt terms, as the subtransient model is derived.
        """
        delta = x[DELTA].real
        im = i_net * 1j * cmath.exp(-1j * delta)
        d_eq2, d_ed2 = self._subtransient(x[EQ1].real, x[EQ2].real, x[ED2].real, im.real, im.imag)
        return -complex(d_ed2, d_eq2) * cmath.exp(1j * delta) / OMEGA0

    def _subtransient(self, eq1: float, eq2: float, ed2: float, i_d: float, i_q: float) -> tuple[float, float]:
        """(de''_q/dt, de''_d/dt): the subtransient windings' equations, written once."""
        p = self.p
        return (eq1 - eq2 - (p.xd1 - p.xd2) * i_d) / p.td02, (-ed2 + (p.xq - p.xd2) * i_q) / p.tq02

    def rhs(self, x, v_term: complex, v_reg: float, e_net: complex | None = None, i_net: complex | None = None):
        """(dx, I): x as an array or a list of 7 floats; ``e_net`` = ``self.e_net(x)`` if known;
        ``i_net`` the stator current when the network computes it (its dynamic-phasor branch), else
        the algebraic (E'' - v)/(r_a + j x''_d)."""
        p = self.p
        delta, w, eq1, eq2, ed2, xll, efd = x.real.tolist() if isinstance(x, np.ndarray) else x
        if e_net is None:
            e_net = complex(eq2, -ed2) * cmath.exp(1j * delta)
        if i_net is None:
            i_net = (e_net - v_term) / self.z2
        im = i_net * 1j * cmath.exp(-1j * delta)
        i_d, i_q = im.real, im.imag
        u = self.v_ref - v_reg - p.m_q * (v_term * i_net.conjugate()).imag
        defd = (p.avr_k * (p.avr_ta_tb * u + (1.0 - p.avr_ta_tb) * xll) - efd) / p.avr_te
        if (efd >= p.efd_max and defd > 0) or (efd <= p.efd_min and defd < 0):
            defd = 0.0
        return [
            OMEGA0 * (w - 1.0),
            (-(ed2 * i_d + eq2 * i_q) - p.d * (w - 1.0)) / (2.0 * p.h),
            (efd - eq1 - (p.xd - p.xd1) * i_d) / p.td01,
            *self._subtransient(eq1, eq2, ed2, i_d, i_q),
            (u - xll) / p.avr_tb,
            defd,
        ], i_net

    def init_state(self, v_term: complex, v_reg: float) -> np.ndarray:
        """No-load steady state (I = 0) at terminal voltage v_term; sets v_ref for zero error drift."""
        p = self.p
        x = np.zeros(NX, dtype=complex)
        vm = abs(v_term)
        x[DELTA] = np.angle(v_term)
        x[OMEGA] = 1.0
        x[EQ1] = vm
        x[EQ2] = vm
        x[ED2] = 0.0
        x[EFD] = vm
        u = vm / p.avr_k
        x[XLL] = u
        self.v_ref = v_reg + u
        return x
