"""The turbines' limiters and DC-link terms, written once for numpy and for numba.

Each function uses only arithmetic and numpy ufuncs (``np.hypot``, ``np.maximum``, ``np.exp``) and
no branch on its arguments (a flag is a bool used as a 0/1 factor), so the same Python function

* runs on arrays of N turbines in the general numpy path (``TurbineBank.rhs`` in plant/turbine.py,
  ``BatteryBank`` in plant/battery.py), and
* compiles for one turbine's scalars with ``numba.njit`` in plant/turbine_kernels.py (the
  compiled path's ``turbines_rhs``).

Where a limiter does not act, its function returns its input exactly (a factor of exactly 1.0, a
clip inside its bounds, a zero power added), so the limited formulas are the only ones: there is
no separate unlimited one. The equations are those of plant/turbine.py's docstring and
plant/battery.py's. Dependencies: numpy only.
"""

from __future__ import annotations

import numpy as np

V_D_FLOOR = 0.3  # grid-following current reference: V_d taken as at least this, p.u.
V_PLL_FLOOR = 0.1  # PLL error: |v| taken as at least this, p.u.
P_CHOP_MAX = 1.5  # braking-chopper power limit, p.u.
SOC_FLOOR = 1e-3  # E_cell has K (1 - SOC)/SOC: evaluated no lower than this


def pll_error(vp_q, v_d, v_q):
    """PLL error e_v = Im(v e^{-j theta}) / |v| (``vp_q`` the first, v = v_d + j v_q), |v| >= 0.1."""
    return vp_q / np.maximum(np.sqrt(v_d * v_d + v_q * v_q), V_PLL_FLOOR)


def gfl_current_ref(s_re, s_im, vp_d, i_max, v_dip, k_qv):
    """Grid-following current reference in the PLL frame, (i*_d, i*_q).

    Normal operation: (P* - j Q*) / V_d with V_d >= 0.3 (``s_re``, ``s_im`` = P*, -Q*; ``vp_d`` =
    Re(v e^{-j theta})), scaled down to |i*| <= i_max keeping its angle (circular limit).
    Fault ride-through (``vp_d`` < ``v_dip`` and ``k_qv`` > 0): an additional reactive current
    k_qv (v_dip - V_d) (capacitive: i_q < 0 here, S = v conj(i)), reactive-current priority: i*_q
    limited to i_max first, i*_d to what is left, sqrt(i_max^2 - i*_q^2). With ``k_qv`` = 0 or
    ``vp_d`` >= ``v_dip`` the result is exactly the normal one."""
    vd = np.maximum(vp_d, V_D_FLOOR)
    dip = np.maximum(v_dip - vp_d, 0.0) * k_qv  # the FRT's additional reactive current, p.u.
    frt = dip > 0.0
    i_d = s_re / vd
    i_q = s_im / vd - dip
    scale = np.minimum(1.0, i_max / np.maximum(np.sqrt(i_d * i_d + i_q * i_q), 1e-9))
    i_q_frt = np.maximum(np.minimum(i_q, i_max), -i_max)
    room = np.sqrt(np.maximum(i_max * i_max - i_q_frt * i_q_frt, 0.0))
    i_d_frt = np.maximum(np.minimum(i_d, room), -room)
    return i_d * scale * (1.0 - frt) + i_d_frt * frt, i_q * scale * (1.0 - frt) + i_q_frt * frt


def modulation_limit(vc_re, vc_im, v_dc, m_max):
    """The converter voltage limited to |v_conv| <= m_max v_dc (scaled down keeping its angle):
    (Re, Im, limited)."""
    vm = np.sqrt(vc_re * vc_re + vc_im * vc_im)
    vmax = m_max * v_dc
    scale = np.minimum(1.0, vmax / np.maximum(vm, 1e-9))
    return vc_re * scale, vc_im * scale, vm > vmax


def remote_current_limit(vr_re, vr_im, v_re, v_im, i_re, i_im, rf, lf, a, i_lim):
    """The converter's local current limit under a received voltage reference (remote mode, v_ref),
    decided for one step: i_p = i + a (v_ref - v - (r_f + j l_f) i), the filter current v_ref would
    reach over the step (forward Euler, ``a`` = h omega0 / l_f); where |i_p| > ``i_lim`` (> 0) the converter
    draws i_c = i_p scaled to i_lim (its angle kept: a circular limit on the current it will draw) with
    v_conv = v + (r_f + j l_f) i + (i_c - i) / a, else v_conv = v_ref exactly. (Re, Im, engaged)."""
    zi_re = rf * i_re - lf * i_im
    zi_im = rf * i_im + lf * i_re
    ip_re = i_re + a * (vr_re - v_re - zi_re)
    ip_im = i_im + a * (vr_im - v_im - zi_im)
    mag = np.sqrt(ip_re * ip_re + ip_im * ip_im)
    on = (mag > i_lim) & (i_lim > 0.0)
    scale = np.minimum(1.0, i_lim / np.maximum(mag, 1e-12))
    f = on * 1.0
    lc_re = v_re + zi_re + (ip_re * scale - i_re) / a
    lc_im = v_im + zi_im + (ip_im * scale - i_im) / a
    return f * lc_re + (1.0 - f) * vr_re, f * lc_im + (1.0 - f) * vr_im, on


def msc_power(e_dc, x_d, p_avail, kp_dc, ki_dc, p_me_min):
    """The machine-side converter's DC-voltage PI, (P_me, dx_d/dt): P_me = clip(kp_dc e_dc + x_d,
    p_me_min, P_avail); its integrator stops while P_me is clipped and the error pushes further out."""
    p_me_u = kp_dc * e_dc + x_d
    p_me = np.maximum(np.minimum(p_me_u, p_avail), p_me_min)
    windup = (p_me_u - p_me) * e_dc > 0.0
    return p_me, ki_dc * e_dc * (1.0 - windup)


def dc_link_control(gfl, v_dc, x_d, p_ref, p_avail, v_dc_ref, kp_dc, ki_dc, p_me_min, p_me_max):
    """Which converter holds the DC link, (P*_gsc, P_me, dx_d/dt); ``gfl`` (0/1): the turbine runs
    grid-following.

    Grid-following (the double-loop control of a Type 4 turbine, CIGRE C4.49 / IEC 61400-27-1): the
    grid-side converter holds the DC voltage, P*_gsc = clip(kp_dc (v_dc - v_dc*) + x_d, p_me_min,
    p_me_max) (its integrator x_d, stopped at the clip), and the machine side follows the speed
    controller's power reference, P_me = clip(p_ref, p_me_min, P_avail).
    Otherwise (hd_visc, remote: the grid side is the ViSC's) the machine side holds it,
    P_me = clip(kp_dc (v_dc* - v_dc) + x_d, p_me_min, P_avail) (``msc_power``).
    In steady state x_d = P either way, so a change of mode keeps it."""
    e_gsc = v_dc - v_dc_ref  # the grid-side PI (as msc_power, written out: numba compiles this function alone)
    p_gsc_u = kp_dc * e_gsc + x_d
    p_gsc = np.maximum(np.minimum(p_gsc_u, p_me_max), p_me_min)
    d_gsc = ki_dc * e_gsc * (1.0 - ((p_gsc_u - p_gsc) * e_gsc > 0.0))
    e_msc = -e_gsc  # the machine-side PI
    p_me_u = kp_dc * e_msc + x_d
    p_me_pi = np.maximum(np.minimum(p_me_u, p_avail), p_me_min)
    d_msc = ki_dc * e_msc * (1.0 - ((p_me_u - p_me_pi) * e_msc > 0.0))
    p_me_follow = np.maximum(np.minimum(p_ref, p_avail), p_me_min)
    return p_gsc, p_me_follow * gfl + p_me_pi * (1.0 - gfl), d_gsc * gfl + d_msc * (1.0 - gfl)


def dc_link_power(p_me, p_conv, p_batt, v_dc, v_chop, k_chop):
    """Net power into the DC link: P_me - P_conv + P_batt - P_chop,
    P_chop = min(k_chop max(v_dc - v_chop, 0), 1.5) (braking chopper)."""
    return p_me - p_conv + p_batt - np.minimum(k_chop * np.maximum(v_dc - v_chop, 0.0), P_CHOP_MAX)


def cell_ocv(soc, e0, k, a, bq):
    """E_cell(SOC), V (Tremblay-Dessaint, no current; plant/battery.py), SOC >= 1e-3."""
    s = np.maximum(soc, SOC_FLOOR)
    return e0 - k * (1.0 - s) / s + a * np.exp(-bq * (1.0 - s))


def battery_current(ocv, v_dc, soc, on, r, i_dis_max, i_chg_max, soc_min, soc_max):
    """Battery current into the DC link (+ = discharging): (OCV - v_dc) / r_b within the C-rate
    limits [-i_chg_max, i_dis_max]; 0 where discharging at SOC <= soc_min, charging at
    SOC >= soc_max, or the battery is not connected (``on`` False)."""
    i = np.minimum(np.maximum((ocv - v_dc) / r, -i_chg_max), i_dis_max)
    blocked = ((i > 0.0) & (soc <= soc_min)) | ((i < 0.0) & (soc >= soc_max))
    return i * (on * (1.0 - blocked))
