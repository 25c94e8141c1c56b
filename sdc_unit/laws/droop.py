"""A droop-based grid-forming law: the SDC's second law, to prove the registry (issue 41).

Droop control of a voltage-source converter [Rocabert, Luna, Blaabjerg, Rodríguez, "Control of power
converters in AC microgrids", IEEE TPEL 27(11), 2012, Section III-A, eqs. (2)-(3)]: the frequency and
the internal-voltage magnitude droop on the low-pass filtered active and reactive power,

    omega = omega* + m_p (P* - P_f),      dP_f/dt = omega_c (P - P_f)
    E     = V* + m_q (Q* - Q_f),          dQ_f/dt = omega_c (Q - Q_f)
    d(delta)/dt = omega0 (omega - 1).

With the power filter this is the swing equation [D'Arco, Suul, "Equivalence of virtual synchronous
machines and frequency-droops for converter-based microgrids", IEEE Trans. Smart Grid 5(1), 2014]:
2H dω/dt = P* − P − D (ω − ω*) with D = 1/m_p and 2H = 1/(m_p ω_c). The defaults take that
equivalence with the ViSC's H = 3 s, D = 90 (sdc_unit.params): m_p = 1/90, ω_c = 90/6 = 15 rad/s, so
the two laws share their small-signal frequency response and differ in the voltage loop (an open
droop here, the ViSC's AVR PI there) and in the virtual friction (none here).

E e^{jδ} drives the same stages as the ViSC (sdc_unit.law_kernels, reused): the voltage filter v_f,
the quasi-stationary virtual impedance i* = (E e^{jδ} − v_f)/(r_v + j ω l_v), the circular limiter and
the inner current PI with voltage feed-forward. Run-time parameters (a REQUEST may set them): v_ref,
q_ref, m_q.

Steady state (the closed form of tests/unit/test_law_droop.py): at constant P, Q the state settles
at P_f = P, Q_f = Q, so ω = 1 + m_p (P* − P) and E = V* + m_q (Q* − Q).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sdc_unit.law_kernels import circular_limit, qsem_current
from sdc_unit.law_spec import LAW_OUTPUTS, Law, param
from sdvisc.vocabulary import F_NOMINAL_HZ, FILTER_R_F_PU, FILTER_X_F_PU, MEAS_FIELDS

STATE_NAMES = ("delta", "p_f", "q_f", "vf_d", "vf_q", "xi_d", "xi_q")
X_DELTA, X_PF, X_QF, X_VFD, X_VFQ, X_XID, X_XIQ = range(len(STATE_NAMES))
PARAM_ROWS = ("p_ref", "m_p", "omega_c", "v_ref", "q_ref", "m_q", "r_v", "l_v", "t_vf", "i_max", "k_pc", "k_ic",
              "l_f", "omega0")
C_P_REF, C_M_P, C_W_C, C_V_REF, C_Q_REF, C_M_Q, C_R_V, C_L_V, C_T_VF, C_I_MAX, C_K_PC, C_K_IC, C_L_F, C_W0 = range(
    len(PARAM_ROWS))
OUT_ROWS = LAW_OUTPUTS
O_VRD, O_VRQ, O_IRD, O_IRQ, O_OMEGA, O_E, O_LIM = range(len(OUT_ROWS))
M_VD, M_VQ, M_ID, M_IQ, M_P, M_Q = (MEAS_FIELDS.index(f) for f in ("v_d", "v_q", "i_d", "i_q", "p", "q"))


@dataclass(frozen=True)
class DroopParams:
    """Parameters of the droop law (per unit on the turbine rating, seconds)."""

    p_ref: float = param(0.0, "p.u.", "as the ViSC's T_m = 0 [paper]: the SDC forms the voltage, the turbine sets P")
    m_p: float = param(1.0 / 90.0, "p.u./p.u.", "D'Arco & Suul 2014: m_p = 1/D with the ViSC's D = 90")
    omega_c: float = param(15.0, "rad/s", "D'Arco & Suul 2014: omega_c = D/(2H) with the ViSC's H = 3 s, D = 90")
    v_ref: float = param(1.0, "p.u.", "nominal voltage [Rocabert 2012: E*]", runtime=True)
    q_ref: float = param(0.0, "p.u.", "as the ViSC's Q* [paper]", runtime=True)
    m_q: float = param(0.02, "p.u.", "the ViSC's reactive droop [paper, comparison case]", runtime=True)
    r_v: float = param(0.0, "p.u.", "the ViSC's virtual impedance [D'Arco 2015]")
    l_v: float = param(0.2, "p.u.", "the ViSC's virtual impedance [D'Arco 2015]")
    t_vf: float = param(1.0 / 300.0, "s", "the ViSC's voltage filter [Mo 2017]")
    i_max: float = param(1.5, "p.u.", "the ViSC's current limit [paper]")
    k_pc: float = param(0.13, "p.u.", "the ViSC's inner loop, sampled at 0.67 ms (docs/sdc.md)")
    k_ic: float = param(1.53, "p.u./s", "the ViSC's inner loop: zero on the filter pole (docs/sdc.md)")
    l_f: float = param(FILTER_X_F_PU, "p.u.", "the converter's filter [D'Arco 2015]")
    r_f: float = param(FILTER_R_F_PU, "p.u.", "the converter's filter [D'Arco 2015]")
    f_base: float = param(F_NOMINAL_HZ, "Hz", "nominal frequency")

    @property
    def omega0(self) -> float:
        return 2.0 * np.pi * float(self.f_base)


def droop_rhs(x, m, c, dx, out):
    """The droop law (module docstring): derivatives into ``dx``, OUT_ROWS into ``out``."""
    vfd, vfq = x[X_VFD], x[X_VFQ]
    omega = 1.0 + c[C_M_P] * (c[C_P_REF] - x[X_PF])
    e_mag = c[C_V_REF] + c[C_M_Q] * (c[C_Q_REF] - x[X_QF])
    isd, isq = qsem_current(e_mag, x[X_DELTA], vfd, vfq, omega, c[C_R_V], c[C_L_V])
    ild, ilq, limited = circular_limit(isd, isq, c[C_I_MAX])
    ed = ild - m[M_ID]
    eq = ilq - m[M_IQ]
    out[O_VRD] = m[M_VD] - c[C_L_F] * m[M_IQ] + c[C_K_PC] * ed + x[X_XID]
    out[O_VRQ] = m[M_VQ] + c[C_L_F] * m[M_ID] + c[C_K_PC] * eq + x[X_XIQ]
    out[O_IRD] = ild
    out[O_IRQ] = ilq
    out[O_OMEGA] = omega
    out[O_E] = e_mag
    out[O_LIM] = limited * 1.0
    dx[X_DELTA] = c[C_W0] * (omega - 1.0)
    dx[X_PF] = c[C_W_C] * (m[M_P] - x[X_PF])
    dx[X_QF] = c[C_W_C] * (m[M_Q] - x[X_QF])
    dx[X_VFD] = (m[M_VD] - vfd) / c[C_T_VF]
    dx[X_VFQ] = (m[M_VQ] - vfq) / c[C_T_VF]
    dx[X_XID] = c[C_K_IC] * ed
    dx[X_XIQ] = c[C_K_IC] * eq


def initial_state(m: np.ndarray, p: DroopParams) -> np.ndarray:
    """Bumpless start from measurement rows ``m`` (MEAS_FIELDS, N): E e^{jδ} = v + j l_v i (ω = 1),
    the power filters where ω = 1 and E is that magnitude (they then relax to the measured P, Q with
    ω_c: the droop moves the operating point smoothly, no step), v_f = v, the current PIs so that
    v_ref = v + (r_f + j l_f) i."""
    v = m[M_VD] + 1j * m[M_VQ]
    i = m[M_ID] + 1j * m[M_IQ]
    e = v + (p.r_v + 1j * p.l_v) * i
    x = np.zeros((len(STATE_NAMES), m.shape[1]))
    x[X_DELTA] = np.angle(e)
    x[X_PF] = p.p_ref
    m_q = np.asarray(p.m_q, dtype=float)
    x[X_QF] = np.where(m_q != 0.0, p.q_ref - (np.abs(e) - p.v_ref) / np.where(m_q != 0.0, m_q, 1.0), m[M_Q])
    x[X_VFD], x[X_VFQ] = v.real, v.imag
    x[X_XID], x[X_XIQ] = p.r_f * i.real, p.r_f * i.imag
    return x


def _bank(n: int, step_s: float, method: str, dtype: str):
    from sdc_unit.law_trapezoid import TrapezoidControllers

    return TrapezoidControllers(LAW, n, step_s, dtype=dtype)


LAW = Law(name="droop", params_type=DroopParams, state_names=STATE_NAMES, out_rows=OUT_ROWS, rhs=droop_rhs,
          param_row_names=PARAM_ROWS, initial_state=initial_state, bank=_bank, methods=("tustin",))
