"""The rest of the farm as one aggregated grid-following converter with the phasor turbine's control
structure (plant/turbine.py, grid-following mode), an average model for the EMT circuit.

The aggregate is the n_agg turbines the SDViSCs are not, behind their turbine transformers in parallel
(the netlist's node ``wt``, its filter capacitors there); every Ts (the SDC's sample period, 13 circuit
steps) it reads the terminal voltage's Park phasor v (raw sample, common frame, turbine base: the network
base and the turbine base of a voltage are the same) and advances, with v held over Ts:

    PLL          e_v = Im(v e^{-j theta}) / max(|v|, 0.1),  dtheta/dt = w0 (kp_pll e_v + x_p),
                 dx_p/dt = ki_pll e_v                                   (TurbineParams kp_pll, ki_pll)
    |v| filter   t_ufilt dV_m/dt = |v| - V_m                            (exact over Ts)
    DC link      (tau_dc/2) d(v_dc^2)/dt = P_me - P_conv - P_chop,  P*_gsc, x_d: the grid side's DC-voltage
                 PI (turbine_laws.dc_link_control, grid-following), P_me held at its start value,
                 P_conv = V_m Re(i e^{-j theta}) [assumed: the power through the converter's |v| filter; with
                 Re(v conj i) of the Ts sample the DC-link PI closes a loop through the circuit's network
                 resonances (~440 Hz at the collector) that grows from the operating point (measured: the
                 farm alone at SCR 7.14, v_dc peak to peak 0.15 p.u. by 0.4 s; at rest, < 1e-7, with V_m)]
    current ref  i* = turbine_laws.gfl_current_ref(P*_gsc, -Q*, V_m, i_max_gfl, frt_v_dip, frt_k_qv) in
                 the PLL frame (V_d floor, circular limit, FRT with reactive priority), Q* = the WPP's order
    current loop i -> i* e^{j theta}: the closed PI loop on the filter, first order with
                 tau_c = (lf / w0) / (kpc + rf) (its integrator's zero at kic/kpc cancels the second pole),
                 exact over Ts

and the circuit's controlled current source injects k_agg i (network base). The same equations as the
phasor turbines' (plant/turbine.py), reduced where they are faster than Ts (the current loop's 0.2 ms)
or slower than the runs (rotor, pitch: P_me constant, which the MPPT's P* = min(w_r^3, 1) is while w_r
holds). Not modelled: the filter's LC dynamics (no converter voltage: the modulation limit does not act),
the active damping (it acts on the filter's resonance), the turbines' individual transformers and array
cables (one equivalent of each), the chopper's effect on the rotor (none: P_me follows P*).
"""

from __future__ import annotations

import cmath
import math

from plant import turbine_laws as laws
from plant.params import TurbineParams
from sdvisc.vocabulary import OMEGA0


class GflAggregate:
    """One aggregated grid-following converter (turbine base per turbine; ``k_agg`` its rating on the
    network base). Start it at rest with :meth:`__init__`'s (v0, i0): the terminal voltage and the
    current the load flow gives it (network base)."""

    def __init__(self, v0: complex, i0_net: complex, k_agg: float, ts: float, turbine: TurbineParams | None = None):
        t = turbine or TurbineParams()
        self.t, self.k, self.ts = t, k_agg, ts
        i0 = i0_net / k_agg
        s0 = v0 * i0.conjugate()
        self.theta, self.xp = cmath.phase(v0), 0.0
        self.vm = abs(v0)
        self.w, self.xd = t.v_dc_ref**2, s0.real  # P*_gsc = x_d at v_dc = 1
        self.p_me = s0.real
        self.q0 = s0.imag
        self.q_star = s0.imag
        self.i = i0
        self.i_ref_dq = i0 * cmath.exp(-1j * self.theta)
        self.v_dc = t.v_dc_ref
        self._a_vm = math.exp(-ts / t.t_ufilt)
        self._a_c = math.exp(-ts / (t.lf / OMEGA0 / (t.kpc + t.rf)))

    def current(self) -> complex:
        """The injection (network base) for the circuit until the next :meth:`sample`."""
        return self.i * self.k

    def sample(self, v: complex) -> complex:
        """Advance by Ts with the terminal voltage ``v`` (network base = turbine base, common frame);
        returns the new injection (network base)."""
        t, ts = self.t, self.ts
        vmag = abs(v)
        rotc = complex(math.cos(self.theta), -math.sin(self.theta))
        vp = v * rotc
        ev = vp.imag / max(vmag, laws.V_PLL_FLOOR)
        self.theta += ts * OMEGA0 * (t.kp_pll * ev + self.xp)
        self.xp += ts * t.ki_pll * ev
        self.vm = vmag + (self.vm - vmag) * self._a_vm
        v_dc = math.sqrt(max(self.w, 1e-4))
        p_gsc, _, dxd = laws.dc_link_control(1.0, v_dc, self.xd, self.p_me, self.p_me, t.v_dc_ref, t.kp_dc,
                                             t.ki_dc, t.p_me_min, t.p_me_max)
        i_d, i_q = laws.gfl_current_ref(float(p_gsc), -self.q_star, self.vm, t.i_max_gfl, t.frt_v_dip, t.frt_k_qv)
        self.i_ref_dq = complex(float(i_d), float(i_q))
        p_conv = self.vm * (self.i * rotc).real  # V_m i_d: the DC link's power through the |v| filter (docstring)
        p_chop = min(t.k_chop * max(v_dc - t.v_chop, 0.0), laws.P_CHOP_MAX)
        self.w += ts * 2.0 / t.tau_dc * (self.p_me - p_conv - p_chop)
        self.xd += ts * float(dxd)
        self.v_dc = v_dc
        i_target = self.i_ref_dq * complex(math.cos(self.theta), math.sin(self.theta))
        self.i = i_target + (self.i - i_target) * self._a_c
        return self.i * self.k
