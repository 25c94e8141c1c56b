"""The law's equations, written once for numpy and for numba.

Each function uses only arithmetic, indexing and numpy ufuncs (``np.cos``, ``np.hypot``,
``np.maximum``) and no branch on its arguments (a flag is a 0.0/1.0 factor), so the same Python
function

* runs on arrays of N turbines in :mod:`sdc_unit.law` (continuous law; ``law_rhs`` with rows of N
  turbines) and in the block-by-block pass of :class:`sdc_unit.discrete.DiscreteVisc`, and
* compiles for scalars with ``numba.njit``: in :mod:`sdc_unit.tustin_jit` (the compiled Tustin
  sample) and :mod:`sdc_unit.law_jit` (``law_rhs`` on one turbine's columns, for the plant's
  compiled hd_visc turbines), where numba maps the ufuncs to the same libm calls numpy makes:
  float64 results are bit-identical between the two (tests/unit/test_sdc_engines.py,
  tests/unit/test_sdc_law_jit.py).

Dependencies: numpy only.
"""

from __future__ import annotations

import numpy as np

#: rows of the law state (docs in sdc_unit.law)
STATE_NAMES = ("delta", "dw", "xi_v", "vf_d", "vf_q", "xi_d", "xi_q", "f_lpf", "f_w1", "f_w2", "f_ll1", "f_ll2")
NX = len(STATE_NAMES)
(IX_DELTA, IX_DW, IX_XIV, IX_VFD, IX_VFQ, IX_XID, IX_XIQ, IX_FLPF, IX_FW1, IX_FW2, IX_FLL1, IX_FLL2) = range(NX)

#: rows of the measurements: sdc_unit.law.Measurements' fields (the wire order, MEAS_FIELDS)
MEAS_ROWS = ("v_d", "v_q", "i_d", "i_q", "p", "q", "v_dc", "omega_meas")
(M_VD, M_VQ, M_ID, M_IQ, M_P, M_Q, M_VDC, M_OMEGA) = range(len(MEAS_ROWS))

#: rows of the parameters: sdc_unit.params.ViscParams' fields the law reads (flags as 0.0/1.0), omega0
PARAM_ROWS = ("h", "d", "p_ref", "omega_s_measured", "v_ref", "q_ref", "e_ref", "m_q", "k_pv", "k_iv", "r_v", "l_v",
              "t_vf", "freeze_vf_when_limited", "i_max", "avr_antiwindup", "supp", "k_f1", "t_v1", "k_f2", "t_v2",
              "t_lpf", "t_1", "t_2", "ff_filtered", "k_pc", "k_ic", "l_f", "omega0")
(P_H, P_D, P_P_REF, P_OMEGA_S_MEASURED, P_V_REF, P_Q_REF, P_E_REF, P_M_Q, P_K_PV, P_K_IV, P_R_V, P_L_V, P_T_VF,
 P_FREEZE_VF, P_I_MAX, P_ANTIWINDUP, P_SUPP, P_K_F1, P_T_V1, P_K_F2, P_T_V2, P_T_LPF, P_T_1, P_T_2, P_FF_FILTERED,
 P_K_PC, P_K_IC, P_L_F, P_OMEGA0) = range(len(PARAM_ROWS))

#: rows of the algebraic outputs of ``law_rhs`` (``limited`` as 0.0/1.0)
OUT_ROWS = ("v_ref_d", "v_ref_q", "i_ref_d", "i_ref_q", "omega", "e_mag", "limited", "v_f", "p_e")
(O_V_REF_D, O_V_REF_Q, O_I_REF_D, O_I_REF_Q, O_OMEGA, O_E_MAG, O_LIMITED, O_V_F, O_P_E) = range(len(OUT_ROWS))


def qsem_current(e_mag, delta, vf_d, vf_q, omega, r_v, l_v):
    """Quasi-stationary electrical model i* = (E e^{j delta} - v_f)/(r_v + j omega l_v); returns (i_d, i_q)."""
    ed = e_mag * np.cos(delta) - vf_d
    eq = e_mag * np.sin(delta) - vf_q
    x = omega * l_v
    den = r_v * r_v + x * x
    return (ed * r_v + eq * x) / den, (eq * r_v - ed * x) / den


def circular_limit(i_d, i_q, i_max):
    """Circular limiter: scale |i| down to i_max keeping the angle. Returns (i_d, i_q, limited).

    The scale is i_max / max(|i|, i_max): exactly 1 while |i| <= i_max (x/x is exact), i_max/|i|
    above it; no division by zero for i_max > 0."""
    mag = np.hypot(i_d, i_q)
    scale = i_max / np.maximum(mag, i_max)
    return i_d * scale, i_q * scale, mag > i_max


def friction_output(f_lpf, f_w1, f_w2, f_ll1, f_ll2, k_f1, t_v1, k_f2, t_v2, t_1, t_2):
    """Algebraic part of eq. (4) given its states: returns (V_F, s1, o1) (s1, o1 feed the lead-lags)."""
    y1 = (k_f1 / t_v1) * (f_lpf - f_w1)
    y2 = (k_f2 / t_v2) * (f_lpf - f_w2)
    s1 = y1 + y2
    r = t_1 / t_2
    o1 = r * s1 + (1.0 - r) * f_ll1
    vf = r * o1 + (1.0 - r) * f_ll2
    return vf, s1, o1


def law_rhs(x, m, c, dx, out):
    """The continuous law (equations in sdc_unit.law) at state ``x``, measurements ``m`` and
    parameters ``c`` (indexed by the rows above): dx/dt into ``dx``, the outputs into ``out``
    (OUT_ROWS). Each ``x[k]``, ``m[k]``, ``c[k]`` is a row of N turbines (numpy) or one turbine's
    value (numba, on columns); ``c[k]`` may also be a scalar shared by all turbines."""
    dw, vfd, vfq = x[IX_DW], x[IX_VFD], x[IX_VFQ]
    measured = c[P_OMEGA_S_MEASURED]
    om_s = measured * m[M_OMEGA] + (1.0 - measured)  # omega_s: measured or nominal
    omega = om_s + dw
    e_avr = (c[P_V_REF] - np.hypot(vfd, vfq)) + c[P_M_Q] * (c[P_Q_REF] - m[M_Q])
    vfr, s1, o1 = friction_output(x[IX_FLPF], x[IX_FW1], x[IX_FW2], x[IX_FLL1], x[IX_FLL2], c[P_K_F1], c[P_T_V1],
                                  c[P_K_F2], c[P_T_V2], c[P_T_1], c[P_T_2])
    vfr = c[P_SUPP] * vfr
    e_mag = c[P_K_PV] * e_avr + x[IX_XIV] + c[P_E_REF] + vfr
    isd, isq = qsem_current(e_mag, x[IX_DELTA], vfd, vfq, omega, c[P_R_V], c[P_L_V])
    ild, ilq, limited = circular_limit(isd, isq, c[P_I_MAX])
    lim = limited * 1.0
    p_e = lim * (m[M_VD] * ild + m[M_VQ] * ilq) + (1.0 - lim) * m[M_P]  # T_e: limited Re(v conj(i_lim)), else p
    ed = ild - m[M_ID]
    eq = ilq - m[M_IQ]
    ff = c[P_FF_FILTERED]  # voltage feed-forward: v_f or the raw sample
    out[O_V_REF_D] = (ff * vfd + (1.0 - ff) * m[M_VD]) - c[P_L_F] * m[M_IQ] + c[P_K_PC] * ed + x[IX_XID]
    out[O_V_REF_Q] = (ff * vfq + (1.0 - ff) * m[M_VQ]) + c[P_L_F] * m[M_ID] + c[P_K_PC] * eq + x[IX_XIQ]
    out[O_I_REF_D] = ild
    out[O_I_REF_Q] = ilq
    out[O_OMEGA] = omega
    out[O_E_MAG] = e_mag
    out[O_LIMITED] = lim
    out[O_V_F] = vfr
    out[O_P_E] = p_e
    dx[IX_DELTA] = c[P_OMEGA0] * (dw + om_s - 1.0)
    dx[IX_DW] = (c[P_P_REF] - p_e - c[P_D] * dw) / (2.0 * c[P_H])
    dx[IX_XIV] = c[P_K_IV] * e_avr * (1.0 - lim * c[P_ANTIWINDUP])  # conditional integration
    run = 1.0 - lim * c[P_FREEZE_VF]
    dx[IX_VFD] = run * (m[M_VD] - vfd) / c[P_T_VF]
    dx[IX_VFQ] = run * (m[M_VQ] - vfq) / c[P_T_VF]
    dx[IX_XID] = c[P_K_IC] * ed
    dx[IX_XIQ] = c[P_K_IC] * eq
    dx[IX_FLPF] = (-dw - x[IX_FLPF]) / c[P_T_LPF]  # input omega_s - omega = -dw
    dx[IX_FW1] = (x[IX_FLPF] - x[IX_FW1]) / c[P_T_V1]
    dx[IX_FW2] = (x[IX_FLPF] - x[IX_FW2]) / c[P_T_V2]
    dx[IX_FLL1] = (s1 - x[IX_FLL1]) / c[P_T_2]
    dx[IX_FLL2] = (o1 - x[IX_FLL2]) / c[P_T_2]
