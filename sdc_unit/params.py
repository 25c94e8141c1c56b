"""Parameters of the virtual synchronous condenser (ViSC) grid-side controller.

All quantities are per unit on the turbine rating (10 MW, 0.69 kV) unless a unit is given; time in
seconds. Sources: ``[paper]`` = the SDViSC paper (/work/shared/reference/sdvisc-paper.tex),
``[D'Arco 2015]`` = D'Arco, Suul, Fosso, EPSR 122 (2015), ``[Mo 2017]`` = Mo, D'Arco, Suul, IEEE TIE 2017,
``[assumed]`` = engineering judgement documented in docs/sdc.md.

Every field may be a Python float or a numpy array of shape (N,) (one value per turbine); the
control law in :mod:`sdc_unit.law` broadcasts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

from sdc_unit.law_spec import param, runtime_names
from sdvisc.vocabulary import F_NOMINAL_HZ, FILTER_R_F_PU, FILTER_X_F_PU, VISC_PARAMS


@dataclass(frozen=True)
class ViscParams:
    """ViSC controller parameters (frozen; use :meth:`with_changes`).

    Inertia emulation, eq. (1):
        h: emulated inertia constant H [s], default 3.0 [paper: 3 s and 5 s cases, 4 s in the 100 MW case].
        d: damping factor D [p.u. torque / p.u. speed], default 90.0 [assumed: swing-mode damping
            ratio ~0.7 for x_v + x_grid ~ 0.42 p.u. (SCR 7.14), D = 4*H*zeta*omega_n].
        p_ref: power reference giving T_m [p.u.], default 0.0 [paper: T_m = 0, no mechanical input].
        omega_s_measured: if True the reference frequency omega_s is the measured grid frequency
            ``meas.omega_meas``; if False omega_s = 1 p.u. (nominal), default False [paper: omega_s
            is a reference].

    AVR with reactive droop, eq. (2):
        v_ref: voltage reference V* [p.u.], default 1.0 [paper].
        q_ref: reactive power reference Q* [p.u.], default 0.0 [paper].
        e_ref: internal voltage feed-forward E* [p.u.], default 1.0 [assumed].
        m_q: reactive droop m_q [p.u./p.u.], default 0.02 [paper, comparison case].
        k_pv: AVR proportional gain K_pv [p.u./p.u.], default 0.5 [assumed, PARAMETERS.md].
        k_iv: AVR integral gain K_iv [1/s], default 20.0 [assumed, PARAMETERS.md].

    Quasi-stationary electrical model (virtual impedance R_vir + j*omega*L_vir):
        r_v: virtual resistance R_vir [p.u.], default 0.0 [D'Arco 2015].
        l_v: virtual inductance L_vir [p.u.], default 0.2 [D'Arco 2015].
        t_vf: time constant of the measured-voltage low-pass filter [s], default 1/300 [Mo 2017].
        freeze_vf_when_limited: freeze that filter while the current limiter saturates, default
            False (Mo 2017 / Dynawo CurrentSaturation freeze it; sampled at 0.67 ms, freezing latched
            the controller at its limit after a dip, see docs/sdc.md).

    Current limiter:
        i_max: circular current limit [p.u.], default 1.5 [paper].
        avr_antiwindup: freeze the AVR integrator while the limiter saturates (conditional
            integration), default True [assumed; without it E winds up to ~6 p.u. during a 0.3 p.u.
            dip and the ViSC stays current-limited for seconds after clearance].

    Virtual friction, eq. (4) (supplementary control), input omega_s - omega as printed: of the two signs
    it is the one that damps, decided by its effect (issue 39 item 7, tests/unit/test_virtual_friction_damping.py:
    the plant + law linearised in the comparison case at SCR 1.9-3.0: the swing mode's damping ratio rises
    with the printed sign (SCR 2.0: 0.719 -> 0.761) and falls flipped (0.656), at both equilibria of SCR 2.0).
    So no "paper-literal" option. With these [assumed] gains the loop adds a 2.3-3.7 Hz mode, at SCR 2.0 with
    damping ratio down to 0.25: the tuning is open, not the sign.
        supp: supplementary control (virtual friction) enabled, default False [assumed; paper uses
            it in the weak-grid cases].
        k_f1: gain K_F1 [p.u. V * s / p.u. speed], default 20.0 [assumed, PARAMETERS.md K_F].
        t_v1: washout time constant T_v1 [s], default 1.0 [assumed].
        k_f2: gain K_F2 [p.u. V * s / p.u. speed], default 0.2 [assumed].
        t_v2: washout time constant T_v2 [s], default 0.02 [assumed].
        t_lpf: input low-pass time constant T_LPF [s], default 0.02 [assumed, PARAMETERS.md].
        t_1: lead time constant T_1 [s], default 0.15 [assumed, PARAMETERS.md].
        t_2: lag time constant T_2 [s], default 0.05 [assumed, PARAMETERS.md].

    Inner current loop (decoupled PI + voltage feed-forward), plant (l_f/omega0) di/dt = v_conv - v - (r_f + j l_f) i:
        k_pc: current PI proportional gain [p.u. V / p.u. A], default 0.13 [assumed: D'Arco's
            1.27 gives a 5000 rad/s loop, above the 4690 rad/s Nyquist rate at Ts = 0.67 ms and
            unstable with the one-sample transport delay; 0.13 gives ~510 rad/s].
        ff_filtered: feed forward the low-pass filtered voltage v_f instead of the raw sample v,
            default False [assumed].
        k_ic: current PI integral gain [p.u. V / (p.u. A * s)], default 1.53 [assumed: zero at the
            filter pole omega0*r_f/l_f = 11.8 rad/s].
        l_f: filter inductance [p.u.], default 0.08 [D'Arco 2015].
        r_f: filter resistance [p.u.], default 0.003 [D'Arco 2015].
        f_base: base (nominal) frequency [Hz], default 50.0 [PARAMETERS.md].
    """

    h: float = param(3.0, "s", "paper: 3 s and 5 s cases, 4 s in the 100 MW case", runtime=True)
    d: float = param(90.0, "p.u.", "assumed: swing-mode damping ratio ~0.7 for x_v + x_grid ~ 0.42 p.u.", runtime=True)
    p_ref: float = param(0.0, "p.u.", "paper: T_m = 0, no mechanical input")
    omega_s_measured: bool = param(False, "", "paper: omega_s is a reference")
    v_ref: float = param(1.0, "p.u.", "paper", runtime=True)
    q_ref: float = param(0.0, "p.u.", "paper", runtime=True)
    e_ref: float = param(1.0, "p.u.", "assumed")
    m_q: float = param(0.02, "p.u.", "paper, comparison case", runtime=True)
    k_pv: float = param(0.5, "p.u./p.u.", "assumed, PARAMETERS.md")
    k_iv: float = param(20.0, "1/s", "assumed, PARAMETERS.md")
    r_v: float = param(0.0, "p.u.", "D'Arco 2015")
    l_v: float = param(0.2, "p.u.", "D'Arco 2015")
    t_vf: float = param(1.0 / 300.0, "s", "Mo 2017")
    freeze_vf_when_limited: bool = param(False, "", "assumed: freezing latched the sampled controller at its limit (docs/sdc.md)")
    i_max: float = param(1.5, "p.u.", "paper")
    avr_antiwindup: bool = param(True, "", "assumed: without it E winds up to ~6 p.u. in a 0.3 p.u. dip")
    supp: bool = param(False, "", "assumed; the paper uses it in the weak-grid cases", runtime=True)
    k_f1: float = param(20.0, "p.u. s", "assumed, PARAMETERS.md K_F")
    t_v1: float = param(1.0, "s", "assumed")
    k_f2: float = param(0.2, "p.u. s", "assumed")
    t_v2: float = param(0.02, "s", "assumed")
    t_lpf: float = param(0.02, "s", "assumed, PARAMETERS.md")
    t_1: float = param(0.15, "s", "assumed, PARAMETERS.md")
    t_2: float = param(0.05, "s", "assumed, PARAMETERS.md")
    ff_filtered: bool = param(False, "", "assumed")
    k_pc: float = param(0.13, "p.u.", "assumed: ~510 rad/s, sampled at 0.67 ms (docs/sdc.md)")
    k_ic: float = param(1.53, "p.u./s", "assumed: zero on the filter pole omega0 r_f/l_f")
    l_f: float = param(FILTER_X_F_PU, "p.u.", "D'Arco 2015")
    r_f: float = param(FILTER_R_F_PU, "p.u.", "D'Arco 2015")
    f_base: float = param(F_NOMINAL_HZ, "Hz", "PARAMETERS.md")

    @property
    def omega0(self) -> float:
        """Base angular frequency [rad/s]."""
        return 2.0 * math.pi * float(self.f_base)

    def with_changes(self, **changes) -> ViscParams:
        """Return a copy with some fields changed."""
        return replace(self, **changes)

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))


RUNTIME_PARAMS: tuple[str, ...] = tuple(sorted(runtime_names(ViscParams), key=list(VISC_PARAMS).index))
"""Parameters that :meth:`sdc_unit.discrete.DiscreteVisc.set_params` may change at run time (those
declared ``runtime=True`` above), in the wire's order: h, d, m_q, v_ref, q_ref, supp."""
