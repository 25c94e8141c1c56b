"""The ViSC grid-side control law in continuous time, vectorised over N turbines.

This module is the single definition of the law. The plant integrates it as the
"hardware-dependent ViSC" ground truth (``derivatives`` / ``outputs``); :mod:`sdc_unit.discrete`
implements the same equations with discretised blocks. The quasi-stationary model and the circular
limiter are written once, in :mod:`sdc_unit.law_kernels`, for this module, the discrete blocks and
the compiled Tustin step alike. Dependencies: numpy only.

Conventions (shared with the plant): per unit on the turbine rating, common frame rotating at
omega0 = 2*pi*f_base, complex vectors x = x_d + j*x_q, converter current positive out of the
converter, S = P + jQ = v * conj(i), time in seconds.

State vector ``x`` has shape (NX, N); row indices (see ``STATE_NAMES``):

====  =========  ====================================================================
row   name       meaning
====  =========  ====================================================================
0     delta      angle of the internal voltage E in the common frame [rad]
1     dw         omega - omega_s, per-unit speed deviation from the reference [p.u.]
2     xi_v       AVR PI integrator, K_iv * integral(e) [p.u.]
3     vf_d       low-pass filtered terminal voltage, d [p.u.]
4     vf_q       low-pass filtered terminal voltage, q [p.u.]
5     xi_d       inner current PI integrator, d [p.u.]
6     xi_q       inner current PI integrator, q [p.u.]
7     f_lpf      virtual friction input low-pass 1/(1+s T_LPF) state [p.u.]
8     f_w1       washout K_F1 s/(1+s T_v1) state [p.u.]
9     f_w2       washout K_F2 s/(1+s T_v2) state [p.u.]
10    f_ll1      first lead-lag (1+sT_1)/(1+sT_2) state [p.u.]
11    f_ll2      second lead-lag state [p.u.]
====  =========  ====================================================================

Equations (per turbine):

* swing, eq. (1) scaled to radians: d(delta)/dt = omega0 * (dw + omega_s - 1),
  2H d(dw)/dt = T_m - T_e - D dw, T_m = p_ref, T_e = p (measured) or, while the limiter
  saturates, Re(v * conj(i_lim)).
* AVR, eq. (2): e = (V* - |v_f|) + m_q (Q* - q); E = K_pv e + xi_v + E* + supp * V_F;
  d(xi_v)/dt = K_iv e, frozen while limited if avr_antiwindup (conditional integration).
* quasi-stationary model: i* = (E e^{j delta} - v_f) / (r_v + j omega l_v), omega = omega_s + dw.
* circular limiter: i_lim = i* * min(1, i_max/|i*|); ``limited`` = |i*| > i_max.
* v_f: d(v_f)/dt = (v - v_f)/t_vf, frozen while limited (if freeze_vf_when_limited).
* virtual friction, eq. (4): input u = omega_s - omega = -dw,
  V_F = u/(1+sT_LPF) * (K_F1 s/(1+sT_v1) + K_F2 s/(1+sT_v2)) * ((1+sT_1)/(1+sT_2))^2.
* inner loop: v_ref = v + j l_f i + k_pc (i_lim - i) + xi_dq, d(xi_dq)/dt = k_ic (i_lim - i).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .law_kernels import circular_limit, qsem_current
from .params import ViscParams

STATE_NAMES = (
    "delta",
    "dw",
    "xi_v",
    "vf_d",
    "vf_q",
    "xi_d",
    "xi_q",
    "f_lpf",
    "f_w1",
    "f_w2",
    "f_ll1",
    "f_ll2",
)
NX = len(STATE_NAMES)
(IX_DELTA, IX_DW, IX_XIV, IX_VFD, IX_VFQ, IX_XID, IX_XIQ, IX_FLPF, IX_FW1, IX_FW2, IX_FLL1, IX_FLL2) = range(NX)


@dataclass
class Measurements:
    """Measurements of N turbines, arrays of shape (N,), per unit, common synchronous frame."""

    v_d: np.ndarray
    v_q: np.ndarray
    i_d: np.ndarray
    i_q: np.ndarray
    p: np.ndarray
    q: np.ndarray
    v_dc: np.ndarray
    omega_meas: np.ndarray

    @classmethod
    def from_complex(cls, v, i, v_dc=1.0, omega_meas=1.0) -> Measurements:
        """Build from complex v, i arrays; p and q computed as v * conj(i)."""
        v = np.atleast_1d(np.asarray(v, dtype=complex))
        i = np.atleast_1d(np.asarray(i, dtype=complex))
        s = v * np.conj(i)
        n = v.shape[0]
        return cls(
            v.real.copy(),
            v.imag.copy(),
            i.real.copy(),
            i.imag.copy(),
            s.real.copy(),
            s.imag.copy(),
            np.broadcast_to(np.asarray(v_dc, dtype=float), (n,)).copy(),
            np.broadcast_to(np.asarray(omega_meas, dtype=float), (n,)).copy(),
        )



@dataclass
class Outputs:
    """Controller outputs, arrays of shape (N,).

    v_ref_d/q: converter terminal voltage reference [p.u.]; i_ref_d/q: limited current reference;
    delta: internal-voltage angle [rad]; omega: ViSC speed [p.u.]; e_mag: |E| [p.u.];
    limited: current limiter active; valid: output is valid (always True from the continuous law);
    v_f: virtual friction output actually applied [p.u.]; p_e: electrical torque used in the swing.
    """

    v_ref_d: np.ndarray
    v_ref_q: np.ndarray
    i_ref_d: np.ndarray
    i_ref_q: np.ndarray
    delta: np.ndarray
    omega: np.ndarray
    e_mag: np.ndarray
    limited: np.ndarray
    valid: np.ndarray
    v_f: np.ndarray
    p_e: np.ndarray


def omega_s_of(meas, p: ViscParams):
    """Reference frequency omega_s [p.u.]: nominal 1.0 or the measured grid frequency."""
    if np.any(np.asarray(p.omega_s_measured)):
        return np.where(np.asarray(p.omega_s_measured, dtype=bool), np.asarray(meas.omega_meas), 1.0)
    return np.ones_like(np.asarray(meas.v_d, dtype=float))


def friction_output(f_lpf, f_w1, f_w2, f_ll1, f_ll2, p: ViscParams):
    """Algebraic part of eq. (4) given its states: returns (V_F, s1, o1) (s1, o1 feed the lead-lags)."""
    y1 = (p.k_f1 / p.t_v1) * (f_lpf - f_w1)
    y2 = (p.k_f2 / p.t_v2) * (f_lpf - f_w2)
    s1 = y1 + y2
    r = p.t_1 / p.t_2
    o1 = r * s1 + (1.0 - r) * f_ll1
    vf = r * o1 + (1.0 - r) * f_ll2
    return vf, s1, o1


def _algebra(x, meas, p: ViscParams):
    x = np.asarray(x, dtype=float)
    om_s = omega_s_of(meas, p)
    dw = x[IX_DW]
    omega = om_s + dw
    vfd, vfq = x[IX_VFD], x[IX_VFQ]
    vmag = np.hypot(vfd, vfq)
    e_avr = (p.v_ref - vmag) + p.m_q * (p.q_ref - meas.q)
    vfr, s1, o1 = friction_output(x[IX_FLPF], x[IX_FW1], x[IX_FW2], x[IX_FLL1], x[IX_FLL2], p)
    vfr_applied = np.where(np.asarray(p.supp, dtype=bool), vfr, 0.0)
    e_mag = p.k_pv * e_avr + x[IX_XIV] + p.e_ref + vfr_applied
    isd, isq = qsem_current(e_mag, x[IX_DELTA], vfd, vfq, omega, p.r_v, p.l_v)
    ild, ilq, limited = circular_limit(isd, isq, p.i_max)
    p_lim = meas.v_d * ild + meas.v_q * ilq
    p_e = np.where(limited, p_lim, meas.p)
    ed = ild - meas.i_d
    eq = ilq - meas.i_q
    ffd, ffq = (vfd, vfq) if p.ff_filtered else (meas.v_d, meas.v_q)
    v_ref_d = ffd - p.l_f * meas.i_q + p.k_pc * ed + x[IX_XID]
    v_ref_q = ffq + p.l_f * meas.i_d + p.k_pc * eq + x[IX_XIQ]
    return dict(
        om_s=om_s,
        omega=omega,
        e_avr=e_avr,
        s1=s1,
        o1=o1,
        vfr=vfr_applied,
        e_mag=e_mag,
        ild=ild,
        ilq=ilq,
        limited=limited,
        p_e=p_e,
        ed=ed,
        eq=eq,
        v_ref_d=v_ref_d,
        v_ref_q=v_ref_q,
    )


def derivatives(x, meas, p: ViscParams):
    """dx/dt of the ViSC law (shape (NX, N)) for state x (NX, N) and measurements ``meas``."""
    x = np.asarray(x, dtype=float)
    a = _algebra(x, meas, p)
    w0 = p.omega0
    dx = np.zeros_like(x)
    dx[IX_DELTA] = w0 * (x[IX_DW] + a["om_s"] - 1.0)
    dx[IX_DW] = (p.p_ref - a["p_e"] - p.d * x[IX_DW]) / (2.0 * p.h)
    hold_v = a["limited"] & np.asarray(p.avr_antiwindup, dtype=bool)
    dx[IX_XIV] = p.k_iv * a["e_avr"] * (1.0 - hold_v)
    run = 1.0 - (a["limited"] & np.asarray(p.freeze_vf_when_limited, dtype=bool))
    dx[IX_VFD] = run * (meas.v_d - x[IX_VFD]) / p.t_vf
    dx[IX_VFQ] = run * (meas.v_q - x[IX_VFQ]) / p.t_vf
    dx[IX_XID] = p.k_ic * a["ed"]
    dx[IX_XIQ] = p.k_ic * a["eq"]
    u = -x[IX_DW]  # omega_s - omega
    dx[IX_FLPF] = (u - x[IX_FLPF]) / p.t_lpf
    dx[IX_FW1] = (x[IX_FLPF] - x[IX_FW1]) / p.t_v1
    dx[IX_FW2] = (x[IX_FLPF] - x[IX_FW2]) / p.t_v2
    dx[IX_FLL1] = (a["s1"] - x[IX_FLL1]) / p.t_2
    dx[IX_FLL2] = (a["o1"] - x[IX_FLL2]) / p.t_2
    return dx


def outputs(x, meas, p: ViscParams) -> Outputs:
    """Algebraic outputs of the law for state x and measurements ``meas``."""
    a = _algebra(x, meas, p)
    x = np.asarray(x, dtype=float)
    n = x.shape[1]
    return Outputs(
        v_ref_d=a["v_ref_d"],
        v_ref_q=a["v_ref_q"],
        i_ref_d=a["ild"],
        i_ref_q=a["ilq"],
        delta=x[IX_DELTA].copy(),
        omega=a["omega"],
        e_mag=a["e_mag"],
        limited=np.asarray(a["limited"], dtype=bool),
        valid=np.ones(n, dtype=bool),
        v_f=a["vfr"],
        p_e=a["p_e"],
    )


def operating_point(meas, p: ViscParams):
    """Internal voltage at the present operating point: E e^{j delta} = v + (r_v + j omega l_v) i.

    Returns (delta [rad], e_mag [p.u.], omega_s, dw). dw is the measured frequency deviation from
    omega_s (0 when omega_s is the measured frequency).
    """
    om_s = omega_s_of(meas, p)
    omega = np.asarray(meas.omega_meas, dtype=float)
    dw = omega - om_s
    x = omega * p.l_v
    ed = meas.v_d + p.r_v * meas.i_d - x * meas.i_q
    eq = meas.v_q + p.r_v * meas.i_q + x * meas.i_d
    return np.arctan2(eq, ed), np.hypot(ed, eq), om_s, dw


def initial_state(meas, p: ViscParams):
    """State (NX, N) for a bumpless start at the present operating point.

    delta and E from v and i through the virtual impedance, v_f = v, the AVR integrator so that
    E is reproduced, the current-PI integrators so that v_ref equals the steady-state converter
    voltage v + (r_f + j l_f) i, friction states at rest (V_F = 0).
    """
    delta, e_mag, _om_s, dw = operating_point(meas, p)
    n = delta.shape[0]
    x = np.zeros((NX, n))
    x[IX_DELTA] = delta
    x[IX_DW] = dw
    vmag = np.hypot(meas.v_d, meas.v_q)
    e_avr = (p.v_ref - vmag) + p.m_q * (p.q_ref - meas.q)
    x[IX_XIV] = e_mag - p.e_ref - p.k_pv * e_avr
    x[IX_VFD] = meas.v_d
    x[IX_VFQ] = meas.v_q
    x[IX_XID] = p.r_f * meas.i_d
    x[IX_XIQ] = p.r_f * meas.i_q
    x[IX_FLPF] = -dw
    x[IX_FW1] = -dw
    x[IX_FW2] = -dw
    return x

