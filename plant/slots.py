"""Named slots of the arrays the compiled kernels read and write (plant/kernels.py).

Each ``IntEnum`` below is generated from one tuple of names. The kernels index with its members
(``constants[Const.kpc]``, ``rows[Row.v_dc, j]``), and the code that fills an array does it by
name (:func:`pack` with a dict), so a position is never written down twice.

``Const``: one float vector of every constant the kernels use -- the turbine gains and their
derived products, the constants of the slow mechanical terms and of the DC-link batteries (read
when a plant is built), and the operating values (grid source, condenser, load, AVR) re-packed after every command. ``Slow``: rows of the held slow terms (N columns). ``Row``: rows of the
real per-turbine results of an evaluation, the measurements first in wire order
(sdvisc.vocabulary.MEAS_FIELDS). ``Scalar``: the complex scalars of an evaluation.
"""

from __future__ import annotations

from enum import IntEnum

import numpy as np

from plant.turbine import CP_OPT, LAMBDA_OPT
from sdvisc.vocabulary import MEAS_FIELDS, OMEGA0


def _slots(name: str, names: tuple[str, ...]) -> type[IntEnum]:
    return IntEnum(name, [(n, i) for i, n in enumerate(names)], module=__name__)


TURBINE_GAINS = (
    "kpc", "kic", "lf", "rf", "w0_over_lf", "w0_rf_over_lf", "w0_kp_pll", "kp_pll", "ki_pll", "m_max",
    "v_dc_ref", "kp_dc", "ki_dc", "two_over_tau_dc", "p_me_min", "v_chop", "k_chop", "i_max_gfl",
    "frt_v_dip", "frt_k_qv", "inv_t_ufilt", "k_ad", "w_ad", "k_ad_ext",
)
SLOW_CONSTANTS = (
    "v_wind_rated", "lambda_opt", "cp_opt", "p_me_max", "p_headroom", "omega_r_ref", "kp_beta", "beta_max",
    "tau_beta", "rate_beta", "ki_beta", "h_rotor",
)
BATTERY_CONSTANTS = (  # plant/battery.py: OCV = ocv_scale E_cell(SOC; cell_*), turbine_laws.battery_current
    "ocv_scale", "cell_e0", "cell_k", "cell_a", "cell_bq", "r_batt", "i_dis_max", "i_chg_max", "soc_min", "soc_max",
)
OPERATING_VALUES = (
    "remote_i_ref",  # 1: remote turbines track the received current reference (remote_apply "i_ref")
    "e_grid", "y_grid_re", "y_grid_im", "y_sc_re", "y_sc_im",
    "load_re", "load_im",  # constant-PQ load at the PCC
    "sc_connected", "avr_at_pcc", "avr_v_ref", "z_sc_re", "z_sc_im", "m_q", "avr_k", "avr_ta_tb",
    "avr_1_minus_ta_tb", "avr_te", "avr_tb", "efd_max", "efd_min", "two_h_sc", "d_sc", "xd_minus_xd1",
    "xd1_minus_xd2", "xq_minus_xd2", "td01", "td02", "tq02",
    "h_grid", "grid_power_scale", "d_grid", "r_gov", "t_gov", "pm0",
)
Const = _slots("Const", TURBINE_GAINS + SLOW_CONSTANTS + BATTERY_CONSTANTS + OPERATING_VALUES)
Slow = _slots("Slow", ("s_ref_re", "s_ref_im", "p_aero_over_2hw", "inv_2hw", "d_beta", "d_xbeta", "p_avail",
                       "p_aero",
                       "battery_on"))  # 1.0: the turbine's battery is connected (set_battery holds them anew)
Row = _slots("Row", (*MEAS_FIELDS, "p_me", "v_conv_re", "v_conv_im", "i_batt"))
Scalar = _slots("Scalar", ("i_sc", "e_grid", "e_sc", "i_load", "f_pcc_pu"))

_INDEX: dict[tuple[str, ...], np.ndarray] = {}


def pack(values: dict[str, float], into: np.ndarray) -> None:
    """Write ``values`` (slot name -> value) into their ``Const`` slots of ``into``."""
    names = tuple(values)
    index = _INDEX.get(names)
    if index is None:
        index = _INDEX[names] = np.array([Const[name] for name in names])
    into[index] = list(values.values())


def turbine_gains(tp) -> dict[str, float]:
    """The turbine gains and derived products (plant.params.TurbineParams ``tp``)."""
    return {
        "kpc": tp.kpc, "kic": tp.kic, "lf": tp.lf, "rf": tp.rf, "w0_over_lf": OMEGA0 / tp.lf,
        "w0_rf_over_lf": OMEGA0 / tp.lf * tp.rf, "w0_kp_pll": OMEGA0 * tp.kp_pll, "kp_pll": tp.kp_pll,
        "ki_pll": tp.ki_pll, "m_max": tp.m_max, "v_dc_ref": tp.v_dc_ref, "kp_dc": tp.kp_dc, "ki_dc": tp.ki_dc,
        "two_over_tau_dc": 2.0 / tp.tau_dc, "p_me_min": tp.p_me_min, "v_chop": tp.v_chop, "k_chop": tp.k_chop,
        "i_max_gfl": tp.i_max_gfl, "frt_v_dip": tp.frt_v_dip, "frt_k_qv": tp.frt_k_qv,
        "inv_t_ufilt": 1.0 / tp.t_ufilt, "k_ad": tp.k_ad, "w_ad": tp.w_ad,
        "k_ad_ext": tp.k_ad if tp.ext_active_damping else 0.0,
    }


def slow_constants(tp) -> dict[str, float]:
    """Constants of the slow mechanical terms (aerodynamics, MSC limit, pitch, rotor)."""
    return {
        "v_wind_rated": tp.v_wind_rated, "lambda_opt": LAMBDA_OPT, "cp_opt": CP_OPT, "p_me_max": tp.p_me_max,
        "p_headroom": tp.p_headroom, "omega_r_ref": tp.omega_r_ref, "kp_beta": tp.kp_beta,
        "beta_max": tp.beta_max, "tau_beta": tp.tau_beta, "rate_beta": tp.rate_beta, "ki_beta": tp.ki_beta,
        "h_rotor": tp.h_rotor,
    }


def battery_constants(batt) -> dict[str, float]:
    """The DC-link batteries' pack constants (plant.battery.BatteryBank ``batt``)."""
    e0, k, a, bq = batt.cell_constants()
    r, i_dis_max, i_chg_max, soc_min, soc_max = batt.current_constants()
    return {
        "ocv_scale": batt.ocv_scale, "cell_e0": e0, "cell_k": k, "cell_a": a, "cell_bq": bq, "r_batt": r,
        "i_dis_max": i_dis_max, "i_chg_max": i_chg_max, "soc_min": soc_min, "soc_max": soc_max,
    }


def operating_values(params, net, sc, load_s: complex, pm0: float) -> dict[str, float]:
    """Grid source, condenser, load and AVR values of the present operating point."""
    g, p = params.grid, sc.p
    yg, ysc, hg = complex(net.y_grid), complex(net.y_sc), g.h_grid > 0
    return {
        "remote_i_ref": 1.0 if params.turbine.remote_apply == "i_ref" else 0.0,
        "e_grid": g.e_grid, "y_grid_re": yg.real, "y_grid_im": yg.imag, "y_sc_re": ysc.real,
        "y_sc_im": ysc.imag, "load_re": load_s.real, "load_im": load_s.imag,
        "sc_connected": 1.0 if net.sc_connected else 0.0, "avr_at_pcc": 1.0 if p.avr_bus == "pcc" else 0.0,
        "avr_v_ref": sc.v_ref, "z_sc_re": sc.z2.real, "z_sc_im": sc.z2.imag, "m_q": p.m_q, "avr_k": p.avr_k,
        "avr_ta_tb": p.avr_ta_tb, "avr_1_minus_ta_tb": 1.0 - p.avr_ta_tb, "avr_te": p.avr_te, "avr_tb": p.avr_tb,
        "efd_max": p.efd_max, "efd_min": p.efd_min, "two_h_sc": 2.0 * p.h, "d_sc": p.d,
        "xd_minus_xd1": p.xd - p.xd1, "xd1_minus_xd2": p.xd1 - p.xd2, "xq_minus_xd2": p.xq - p.xd2,
        "td01": p.td01, "td02": p.td02, "tq02": p.tq02,
        "h_grid": g.h_grid, "grid_power_scale": g.s_base_mva / g.s_grid_mva if hg else 0.0,
        "d_grid": g.d_grid if hg else 0.0, "r_gov": g.r_gov if hg else 1.0, "t_gov": g.t_gov if hg else 1.0,
        "pm0": pm0,
    }
