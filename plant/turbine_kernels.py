"""The turbines' right-hand side compiled with numba: ``turbines_rhs`` (plant/kernels.py calls it).

The equations are those of ``TurbineBank.rhs`` (plant/turbine.py) for the held slow terms, every
limiter included: the V_d floor and grid-following current limit, the modulation limit (which
freezes the current-PI integrator), the MSC power clip with its anti-windup, the braking chopper
and the DC-link battery. Those are not written here a second time: they are the functions of
plant/turbine_laws.py, compiled as written (the numpy path runs them on arrays).

The functions here are not cached on disk themselves; the cached kernels that compile them in
(plant/kernels.py, plant/visc_kernels.py) carry a hash of this file and of turbine_laws.py in their
cache key (``sdc_unit.law_jit.source_key``).

Arguments as in plant/kernels.py, and ``soc`` the batteries' states of charge, held over the
evaluation (plant/battery.py; the row ``Slow.battery_on`` of ``slow`` says which are connected).
"""

from __future__ import annotations

import math

from numba import njit

from plant import turbine_laws as laws
from plant.slots import Const, Row, Slow
from plant.turbine import AD, GFL, IF, REMOTE, TH, VM, WR, XB, XD, XI, XP, B, W
from sdvisc.vocabulary import OMEGA0

_OPTS = dict(error_model="numpy")  # IEEE division as in numpy

pll_error = njit(**_OPTS)(laws.pll_error)
gfl_current_ref = njit(**_OPTS)(laws.gfl_current_ref)
modulation_limit = njit(**_OPTS)(laws.modulation_limit)
remote_current_limit = njit(**_OPTS)(laws.remote_current_limit)
msc_power = njit(**_OPTS)(laws.msc_power)
dc_link_power = njit(**_OPTS)(laws.dc_link_power)
dc_link_control = njit(**_OPTS)(laws.dc_link_control)
cell_ocv = njit(**_OPTS)(laws.cell_ocv)
battery_current = njit(**_OPTS)(laws.battery_current)


@njit(inline="always", **_OPTS)
def _write_rows(rows, j, v, i, v_dc, omega_meas, p_me, v_conv, i_batt):
    rows[Row.v_d, j] = v.real
    rows[Row.v_q, j] = v.imag
    rows[Row.i_d, j] = i.real
    rows[Row.i_q, j] = i.imag
    rows[Row.p, j] = v.real * i.real + v.imag * i.imag
    rows[Row.q, j] = v.imag * i.real - v.real * i.imag
    rows[Row.v_dc, j] = v_dc
    rows[Row.omega_meas, j] = omega_meas
    rows[Row.p_me, j] = p_me
    rows[Row.v_conv_re, j] = v_conv.real
    rows[Row.v_conv_im, j] = v_conv.imag
    rows[Row.i_batt, j] = i_batt


@njit(**_OPTS)
def battery_current_of(constants, v_dc, soc):
    """The battery current of a turbine whose battery is connected, at its held ``soc``."""
    ocv = constants[Const.ocv_scale] * cell_ocv(soc, constants[Const.cell_e0], constants[Const.cell_k],
                                                constants[Const.cell_a], constants[Const.cell_bq])
    return battery_current(ocv, v_dc, soc, True, constants[Const.r_batt], constants[Const.i_dis_max],
                           constants[Const.i_chg_max], constants[Const.soc_min], constants[Const.soc_max])


@njit(**_OPTS)
def turbines_rhs(X, node_v, constants, slow, mode, v_ext, i_hold, soc, dX, rows, want):
    """Turbine derivatives into dX (and, ``want``, the results into ``rows``)."""
    n = slow.shape[1]
    w0_over_lf, w0_rf_over_lf = constants[Const.w0_over_lf], constants[Const.w0_rf_over_lf]
    w0_kp_pll, kp_pll, ki_pll = constants[Const.w0_kp_pll], constants[Const.kp_pll], constants[Const.ki_pll]
    m_max, v_dc_ref = constants[Const.m_max], constants[Const.v_dc_ref]
    kp_dc, ki_dc, two_over_tau_dc = constants[Const.kp_dc], constants[Const.ki_dc], constants[Const.two_over_tau_dc]
    p_me_min, v_chop, k_chop = constants[Const.p_me_min], constants[Const.v_chop], constants[Const.k_chop]
    p_me_max = constants[Const.p_me_max]
    kpc, kic, i_max = constants[Const.kpc], constants[Const.kic], constants[Const.i_max_gfl]
    v_dip, k_qv = constants[Const.frt_v_dip], constants[Const.frt_k_qv]
    inv_t_ufilt, k_ad, w_ad = constants[Const.inv_t_ufilt], constants[Const.k_ad], constants[Const.w_ad]
    k_ad_ext = constants[Const.k_ad_ext]
    j_lf = complex(0.0, constants[Const.lf])
    z_filter = complex(constants[Const.rf], constants[Const.lf])
    remote_i_ref = constants[Const.remote_i_ref] != 0.0
    for j in range(n):
        v = node_v[j]
        i = X[IF * n + j]
        theta = X[TH * n + j].real
        x_pll = X[XP * n + j].real
        to_pll = complex(math.cos(theta), -math.sin(theta))  # e^{-j theta}
        v_pll = v * to_pll
        e_v = pll_error(v_pll.imag, v.real, v.imag)
        j_lf_i = j_lf * i
        v_dc = math.sqrt(max(X[W * n + j].real, 1e-4))
        gfl = 1.0 if mode[j] == GFL else 0.0
        p_gsc, p_me, d_xd = dc_link_control(gfl, v_dc, X[XD * n + j].real, slow[Slow.s_ref_re, j],
                                            slow[Slow.p_avail, j], v_dc_ref, kp_dc, ki_dc, p_me_min, p_me_max)
        if mode[j] != GFL:  # remote / hd_visc: v_conv given, current-PI integrator frozen
            if remote_i_ref and mode[j] == REMOTE:  # local loop on the received current reference
                i_ref = i_hold[j]
                v_conv = v + z_filter * i_ref + kpc * (i_ref - i)
            else:
                v_conv = v_ext[j]
            v_conv = v_conv - k_ad_ext * (v - X[AD * n + j])  # the converter's own active damping
            g = v_conv - v - j_lf_i
            e_i = 0j
        else:
            i_ref_d, i_ref_q = gfl_current_ref(p_gsc, slow[Slow.s_ref_im, j], X[VM * n + j].real, i_max, v_dip,
                                               k_qv)
            e_i = complex(i_ref_d, i_ref_q) - i * to_pll
            g = (kpc * e_i + kic * X[XI * n + j]) * to_pll.conjugate() - k_ad * (v - X[AD * n + j])
            v_conv = v + j_lf_i + g
        vc_re, vc_im, limited = modulation_limit(v_conv.real, v_conv.imag, v_dc, m_max)
        if limited:  # the current-PI integrator is frozen while DC-limited
            v_conv = complex(vc_re, vc_im)
            g = v_conv - v - j_lf_i
            e_i = 0j
        i_batt = battery_current_of(constants, v_dc, soc[j]) if slow[Slow.battery_on, j] != 0.0 else 0.0
        p_conv = v_conv.real * i.real + v_conv.imag * i.imag
        p_dc = dc_link_power(p_me, p_conv, v_dc * i_batt, v_dc, v_chop, k_chop)
        dX[IF * n + j] = complex(w0_over_lf * g.real - w0_rf_over_lf * i.real,
                                 w0_over_lf * g.imag - w0_rf_over_lf * i.imag)
        dX[XI * n + j] = e_i
        dX[TH * n + j] = w0_kp_pll * e_v + OMEGA0 * x_pll
        dX[XP * n + j] = ki_pll * e_v
        dX[W * n + j] = two_over_tau_dc * p_dc
        dX[XD * n + j] = d_xd
        dX[WR * n + j] = slow[Slow.p_aero_over_2hw, j] - p_me * slow[Slow.inv_2hw, j]
        dX[B * n + j] = slow[Slow.d_beta, j]
        dX[XB * n + j] = slow[Slow.d_xbeta, j]
        dX[VM * n + j] = (abs(v) - X[VM * n + j].real) * inv_t_ufilt
        dX[AD * n + j] = (v - X[AD * n + j]) * w_ad
        if want:
            _write_rows(rows, j, v, i, v_dc, (kp_pll * e_v + x_pll) + 1.0, p_me, v_conv, i_batt)


@njit(cache=True, **_OPTS)
def local_current_limit(X, v, rem, v_sdc, v_hold, last_rx_step, k, rf, lf, a, i_lim, k_ad, m_max):
    """The remote converters' local current limit for one plant step (``Commands._local_current_limit``):
    for each turbine of ``rem``, the v_ref received this step (``last_rx_step`` == ``k``) kept in ``v_sdc``;
    ``v_hold`` (applied) set to the local limit's voltage where ``turbine_laws.remote_current_limit``
    engages on v_sdc less the active damping ``k_ad`` (v - phi) within the modulation limit, else to
    v_sdc. ``X`` the plant's flat state, ``v`` the turbines' terminal voltages at it. Returns whether any
    v_hold changed."""
    n = v_hold.shape[0]
    changed = False
    for r in range(rem.shape[0]):
        j = rem[r]
        if last_rx_step[j] == k:
            v_sdc[j] = v_hold[j]
        i = X[IF * n + j]
        damping = k_ad * (v[j] - X[AD * n + j])
        vr = v_sdc[j] - damping
        v_dc = math.sqrt(max(X[W * n + j].real, 1e-4))
        vr_re, vr_im, _ = modulation_limit(vr.real, vr.imag, v_dc, m_max)
        lr, li, on = remote_current_limit(vr_re, vr_im, v[j].real, v[j].imag, i.real, i.imag, rf, lf, a, i_lim)
        applied = complex(lr, li) + damping if on else v_sdc[j]
        if applied != v_hold[j]:
            v_hold[j] = applied
            changed = True
    return changed
