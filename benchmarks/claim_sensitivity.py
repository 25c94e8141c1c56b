"""Sensitivity of every printed number of the paper the offline testbed does not reproduce within 10 %
(issue 28, build item 10): which defensible parameters move it, each over the range its source
allows, and whether any defensible value reaches the paper's number.

One-at-a-time (tornado): every parameter at the low and at the high end of its range, the others at
their defaults; then the "best corner" (each range parameter at whichever end moved the number
towards the paper, all together). Two kinds of variation, kept apart in the output:

* ``range``: a parameter with a source and a range (``Param.source`` says which and why);
* ``ambiguity``: a choice the paper leaves open (which bus or measure a figure shows, the SCR of a
  case it does not state, whether a device the paper does not mention is in service). These are
  alternatives, not ranges, and are not combined into the corner.

Claims (quick report, `.venv/bin/python -m report --quick --only F3,F6,F7,F8,F9`, 2026-12-03):
F6.d (SDViSC residual voltage ≈ 0.6 p.u.), F7.b (SC boundary SCR 1.58), F8.a (0.97 → 1.02 p.u.),
F8.c (0.4 p.u. during the fault, no SDViSC), F9.a/F9.c/F9.d (3 SDViSCs stable until ≈ 3 s, 4
needed), C1.b (settling ≈ 0.1 s; a network experiment, here its offline analogue: the continuous
law, no network). Every run is offline (plant.cases, the continuous law hd_visc), in this one
process. Each claim is measured the way its report experiment measures it (report/exp_grid.py,
exp_weak.py, exp_parallel.py, exp_cyber.py), with the report's own stability criterion
(report/stability.py), bisection (report/boundary.py) and verdict rules (report/verdicts.py).

Usage (from the checkout; report/ is not an installed package):
    PYTHONPATH=. .venv/bin/python benchmarks/claim_sensitivity.py [--out DIR] [--date YYYY-MM-DD]
        [--only F6.d,F7.b,F8,F9,C1.b]
Writes DIR/claim-sensitivity-<date>.json and one PNG per claim (DIR/<claim>-<date>.png); default DIR
benchmarks/measured/claim-sensitivity/.
"""

from __future__ import annotations

import argparse
import contextlib
import datetime
import json
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy.optimize import brentq  # noqa: E402

import plant.cases as cases  # noqa: E402
from plant.params import PlantParams  # noqa: E402
from plant.sim import Plant  # noqa: E402
from report.boundary import smallest_sufficient, threshold  # noqa: E402
from report.fault_readings import R_F_RANGE_OHM, ohm_to_pu  # noqa: E402
from report.network_runs import settle_time  # noqa: E402
from report.stability import of_run  # noqa: E402
from report.verdicts import change_close_to, close_to  # noqa: E402
from sdc_unit.params import ViscParams  # noqa: E402

RANGE, AMBIGUITY = "range", "ambiguity"


@dataclass(frozen=True)
class Param:
    """One parameter (or one open choice of the paper's) and the values it is tried at."""

    name: str
    changes: dict  # value label -> {"part.field": value}; the first entry is the low end, the last the high end
    default: str  # what the default is, in words
    source: str  # where the range comes from, and why these ends
    kind: str = RANGE


def pll(kp: float, ki: float) -> dict:
    return {"turbine.kp_pll": kp, "turbine.ki_pll": ki}


# ------------------------------------------------------------------------------------ the parameters
# Sources: Kundur, Power System Stability and Control (1994), Table 4.2 (typical synchronous machine
# parameters, thermal units: x''d 0.12-0.25, x'd 0.15-0.4, T'd0 3-10 s, T''d0 0.02-0.05 s);
# IEC 60076-5 Table 1 (recognised minimum short-circuit impedance of two-winding transformers: 8 %
# for 6.3-25 MVA, 10 % for 25-40 MVA); VDE-AR-N 4120:2018 (FRT k = 2, range 2-6); ENTSO-E RfG
# (EU 2016/631) Art. 21(3)(d) (voltage-control slope 2-7 %, 90 % of a step within 1-5 s) and
# Art. 25(5) Table 9 (total Q/P_max range 0.5-0.95 by synchronous area); IEEE C62.92 / IEC 60071-1
# (effectively grounded: X0/X1 <= 3); the paper's own values where it prints several.
SC_XD2 = Param("SC x''d", {"0.12": {"condenser.xd2": 0.12}, "0.25": {"condenser.xd2": 0.25}}, "0.20",
               "Kundur Table 4.2, thermal units 0.12-0.25 (PARAMETERS.md: 0.20 typical)")
SC_XD1 = Param("SC x'd", {"0.25": {"condenser.xd1": 0.25}, "0.40": {"condenser.xd1": 0.40}}, "0.30",
               "Kundur Table 4.2, 0.15-0.4; low end 0.25 to stay above x''d = 0.20")
SC_XD = Param("SC x_d", {"1.0": {"condenser.xd": 1.0, "condenser.xq": 0.95},
                         "2.3": {"condenser.xd": 2.3, "condenser.xq": 2.2}}, "1.8 (x_q 1.7)",
              "Kundur Table 4.2, thermal units x_d 1.0-2.3 (x_q moved with it)")
SC_TD01 = Param("SC T'd0", {"3 s": {"condenser.td01": 3.0}, "10 s": {"condenser.td01": 10.0}}, "7 s",
                "Kundur Table 4.2, 3-10 s")
SC_TD02 = Param("SC T''d0", {"0.02 s": {"condenser.td02": 0.02}, "0.05 s": {"condenser.td02": 0.05}}, "0.04 s",
                "Kundur Table 4.2, 0.02-0.05 s")
SC_XTR = Param("SC step-up x", {"0.10": {"condenser.x_tr": 0.10}, "0.15": {"condenser.x_tr": 0.15}}, "0.12",
               "IEC 60076-5 Table 1: at least 10 % for 25-40 MVA; 15 % the usual upper end of large step-ups")
SC_H = Param("SC H", {"1.0 s": {"condenser.h": 1.0}, "2.0 s": {"condenser.h": 2.0}}, "1.2 s",
             "[assumed] condensers without flywheel 1-2 s (PARAMETERS.md: 1.2 typical)")
SC_AVR_K = Param("SC AVR gain K", {"100": {"condenser.avr_k": 100.0}, "400": {"condenser.avr_k": 400.0}}, "200",
                 "[assumed] static exciters 100-400 around Kundur's two-area SEXS K = 200")
SC_AVR_BUS = Param("SC AVR senses", {"PCC": {"condenser.avr_bus": "pcc"}}, "its terminal",
                   "the paper: 'AVR droop 0.02', bus not stated (IEEE 421.5: the terminal)", AMBIGUITY)
PLL = Param("PLL bandwidth", {"47 rad/s": pll(0.15, 3.6), "157 rad/s": pll(0.5, 40.0)}, "79 rad/s (k_p 0.25, k_i 10)",
            "[assumed] grid-following PLLs 7.5-25 Hz; damping ratio 0.7 kept: k_i = (w0 k_p / (2 zeta))^2 / w0")
FRT = Param("FRT k", {"2": {"turbine.frt_k_qv": 2.0}, "6": {"turbine.frt_k_qv": 6.0}}, "2",
            "VDE-AR-N 4120:2018: k = 2 default, 2-6 allowed")
WPP_KI = Param("plant controller k_i", {"2": {"wpp.k_i": 2.0}, "10": {"wpp.k_i": 10.0}}, "10 (t90 ~ 1 s)",
               "ENTSO-E RfG Art. 21(3)(d)(iv): 90 % of a step within 1-5 s, i.e. k_i 10 (1 s) down to 2 (5 s)")
WPP_DROOP = Param("plant controller droop", {"0.02": {"wpp.droop": 0.02}, "0.07": {"wpp.droop": 0.07}}, "0.04",
                  "ENTSO-E RfG Art. 21(3)(d): slope 2-7 %")
WPP_QMAX = Param("plant controller Q limit", {"0.25": {"wpp.q_max": 0.25}, "0.475": {"wpp.q_max": 0.475}},
                 "0.33 (pf 0.95)", "ENTSO-E RfG Art. 25(5) Table 9: total Q/P_max range 0.5-0.95, i.e. +-0.25 to +-0.475")
WPP_OFF = Param("plant voltage controller", {"off (unity-pf farm)": {"wpp.enabled": False}}, "in service",
                "the paper does not mention one (its farm is CIGRE C4.49's, whose plant controls the PCC)", AMBIGUITY)
X_TTR = Param("turbine transformer x", {"0.08": {"grid.x_ttr": 0.08}, "0.10": {"grid.x_ttr": 0.10}}, "0.08",
              "IEC 60076-5 Table 1: at least 8 % for 6.3-25 MVA (11 MVA); 10 % a usual upper value")
X_ONSHORE = Param("SDViSC step-up x", {"0.10": {"plant.x_onshore_step_up": 0.10},
                                       "0.15": {"plant.x_onshore_step_up": 0.15}}, "0.12",
                  "IEC 60076-5 Table 1: at least 10 % for 25-40 MVA; 15 % the usual upper end")
K0 = Param("grid Z0/Z1", {"0.5": {"grid.k0_grid": 0.5}, "3.0": {"grid.k0_grid": 3.0}}, "1.0",
           "[assumed] 0.5 (a bus with several grounded-star transformers) to 3 (IEEE C62.92 / IEC 60071-1: "
           "effectively grounded X0/X1 <= 3)")
Z_F = Param("fault resistance", {f"{r:g} ohm": {"case.z_f": ohm_to_pu(r, 500.0)} for r in (0.0, 15.0, R_F_RANGE_OHM[1])},
            "0 (bolted)", "report/fault_readings.py R_F_RANGE_OHM: 0 at the source, 15 ohm on a line with ground "
            "wires, 50 ohm without (cited there), at 400 kV on 500 MVA (320 ohm); the paper does not state it: a "
            "value reached only through it is 'consistent', not reproduced", AMBIGUITY)
V_STAR = Param("SDViSC V*", {"1.00": {"visc.v_ref": 1.0}, "1.04": {"visc.v_ref": 1.04}}, "1.00",
               "the paper's own AVR references (Fig. Compare_Volg: 1.00 -> 1.04)")
VISC_D = Param("SDViSC D", {"50": {"visc.d": 50.0}, "130": {"visc.d": 130.0}}, "90 (zeta 0.7)",
               "[assumed] PARAMETERS.md: D for a swing-mode damping ratio ~0.7; zeta 0.4-1.0 gives D 50-130")
VISC_H = Param("SDViSC H", {"3 s": {"visc.h": 3.0}, "5 s": {"visc.h": 5.0}}, "3 s", "the paper's H values (3, 4, 5 s)")
VISC_KIV = Param("SDViSC K_iv", {"5": {"visc.k_iv": 5.0}, "20": {"visc.k_iv": 20.0}}, "20 (T_v 0.05 s)",
                 "not a sourced range: the paper varies T_v = 1/K_iv (Fig. Compare_Volg (b)) without printing its "
                 "values, and no published range was found; 5 and 20 are the values report F3 runs", AMBIGUITY)
VISC_KPV = Param("SDViSC K_pv", {"0.25": {"visc.k_pv": 0.25}, "1.0": {"visc.k_pv": 1.0}}, "0.5",
                 "[assumed] a factor 2 around PARAMETERS.md's example 0.5 (no published value)")
VISC_LV = Param("SDViSC L_vir", {"0.1": {"visc.l_v": 0.1}, "0.3": {"visc.l_v": 0.3}}, "0.2",
                "[assumed] +-50 % around D'Arco 2015's 0.2 p.u.")
VISC_MQ = Param("SDViSC m_q", {"0.02": {"visc.m_q": 0.02}, "0.10": {"visc.m_q": 0.10}}, "0.02",
                "the paper's droops (0.02 comparison, 0.03-0.10 parallel)")
FRICTION = Param("virtual friction (eq. 4)", {"on": {"visc.supp": True}}, "off",
                 "the paper designs it for weak grids; not said whether its Fig. study2_Weak_noVSC uses it", AMBIGUITY)

F6D_PARAMS = (X_ONSHORE, X_TTR, K0, Z_F, FRT, VISC_LV)
F7B_PARAMS = (SC_XD2, SC_XD1, SC_XD, SC_TD01, SC_TD02, SC_XTR, SC_H, SC_AVR_K, PLL, FRT, WPP_KI, WPP_DROOP, WPP_QMAX,
              SC_AVR_BUS, WPP_OFF)
F8_SCR = Param("SCR of the case", {"4.0": {"case.scr": 4.0}, "3.0": {"case.scr": 3.0}}, "7.14",
               "not printed for Fig. study2_VSC_reg (its Fig. Compare_ShortC says 7.14); the farm alone is stable "
               "above ~2.1 (F7.a)", AMBIGUITY)
F8_OPEN = Param("open choices together", {
    "SCR 4.0, no plant controller": {"case.scr": 4.0, "wpp.enabled": False},
    "SCR 3.0, no plant controller": {"case.scr": 3.0, "wpp.enabled": False},
    "SCR 3.0, no plant controller, V* 1.04": {"case.scr": 3.0, "wpp.enabled": False, "visc.v_ref": 1.04},
    "SCR 2.5, no plant controller, V* 1.04": {"case.scr": 2.5, "wpp.enabled": False, "visc.v_ref": 1.04}},
    "SCR 7.14, plant controller in service, V* 1.00",
    "the SCR and the plant controller as above; V* at the paper's 1.04 with them", AMBIGUITY)
F8_WPP_ON = Param("plant voltage controller", {"in service (PCC voltage control)": {"wpp.enabled": True}},
                  "reactive-power mode at Q* = 0 (unity-pf farm), as report F8: the paper's 0.97 is 'below the "
                  "rated voltage', a farm not regulating its PCC", "the paper does not mention one", AMBIGUITY)
F8_PARAMS = (V_STAR, WPP_QMAX, WPP_DROOP, X_TTR, K0, Z_F, FRT, PLL, F8_SCR, F8_WPP_ON, F8_OPEN)
F9_PARAMS = (VISC_D, VISC_H, VISC_KIV, VISC_KPV, VISC_LV, VISC_MQ, PLL, FRT, WPP_KI, WPP_DROOP, WPP_QMAX, FRICTION, WPP_OFF)
C1_PRODUCING = Param("plugged turbine before the plug", {"at P = 0": {"case.p_before_zero": True}},
                     "producing (as the network scenario)", "the paper does not say; its ViSC has T_m = 0", AMBIGUITY)
C1_PARAMS = (VISC_H, VISC_D, VISC_KIV, VISC_KPV, VISC_LV, FRT, PLL, WPP_KI, C1_PRODUCING, WPP_OFF)


# ------------------------------------------------------------------------------ building the cases
def _split(changes: dict) -> tuple[dict, dict, dict]:
    """(plant-parameter changes, ViscParams changes, case options)."""
    plant_ch, visc, case = {}, {}, {}
    for key, value in changes.items():
        part, field = key.split(".", 1)
        {"visc": visc, "case": case}.get(part, plant_ch)[key if part not in ("visc", "case") else field] = value
    return plant_ch, visc, case


def _apply(pp: PlantParams, plant_ch: dict) -> PlantParams:
    for key, value in plant_ch.items():
        part, field = key.split(".", 1)
        obj = pp if part == "plant" else getattr(pp, part)
        if not hasattr(obj, field):
            raise TypeError(f"unknown parameter {key!r}")
        setattr(obj, field, value)
    return pp


@contextlib.contextmanager
def patched(plant_ch: dict):
    """plant.cases builds its PlantParams with ``plant_ch`` applied (the cases' own set-up otherwise)."""
    original = cases._params
    cases._params = lambda sc_connected, grid: _apply(original(sc_connected, grid), plant_ch)
    try:
        yield
    finally:
        cases._params = original


def _grid_keys(case: dict) -> dict:
    return {"scr": case["scr"]} if "scr" in case else {}


# --------------------------------------------------------------------------------- the measurements
def _fault_events(z_f: float):
    return [(1.0, lambda q: q.fault(True, z_f)), (1.2, lambda q: q.fault(False))]


def _during(r: dict) -> np.ndarray:
    return (r["t"] >= 1.05) & (r["t"] < 1.19)  # report/exp_grid.py and exp_parallel.py: 1.05-1.19 s


def eval_f6d(changes: dict) -> dict:
    """The 40 MVA SDViSC's terminal V1 during the SLG fault 1.0-1.2 s (report F6.d), the PCC beside."""
    plant_ch, visc, case = _split(changes)
    with patched(plant_ch):
        p = cases.comparison_visc_plant(visc_params=ViscParams(**visc), **_grid_keys(case))
    r = p.run_offline(1.25, events=_fault_events(case.get("z_f", 0.0)), record_every=5)
    f = _during(r)
    ph = r["v_pcc_ph"][f].mean(axis=0)
    return {"terminal V1": float(r["v_wt"][f, cases.COMPARISON_UNIT].mean()), "PCC V1": float(r["v_pcc"][f].mean()),
            "PCC phase RMS, mean of 3": float(ph.mean()), "PCC phase RMS, lowest": float(ph.min())}


F7_RANGE, F7_XTOL, F7_T_END = (1.2, 3.0), 0.05, 4.0  # the full report's 4 s runs; bisection to 0.05


def eval_f7b(changes: dict) -> dict:
    """The SC case's stable boundary (report F7.b: SCR 7.14 -> s at 1 s, stable = damped and in band)."""
    plant_ch, _, _ = _split(changes)

    def stable(scr: float) -> bool:
        with patched(plant_ch):
            p = cases.sc_plant()
        with np.errstate(all="ignore"):
            r = p.run_offline(F7_T_END, events=[(1.0, lambda q: q.set_scr(scr))], record_every=10)
        return of_run(r, 1.0).stable

    b = threshold(stable, *F7_RANGE, F7_XTOL)
    return {"boundary": b.value, "bracket": b.bracket, "evaluations": b.evaluations, "note": b.note}


M_Q = np.array([0.03, 0.05, 0.07, 0.10])  # report/exp_parallel.py


def eval_f8(changes: dict) -> dict:
    """F8 as report/exp_parallel.py: the grid EMF for V_pcc = 0.97 (brentq), the four SDViSCs (m_q
    0.03-0.10) activated at 1 s (F8.a: the rise), the SLG fault 1.0-1.2 s without them (F8.c)."""
    plant_ch, visc, case = _split(changes)
    vp = ViscParams(m_q=M_Q, **visc)
    grid = {**_grid_keys(case), "wpp_enabled": False}  # as report F8 (``patched`` may put it back in service)
    with patched(plant_ch):
        def error(e: float) -> float:
            try:
                return float(cases.visc_plant(4, vp, activate=False, e_grid=e, **grid).outputs()["v_pcc"]) - 0.97
            except RuntimeError:  # no load flow at this EMF
                return -0.97
        e = _grid_emf(error)
        if e is None:
            return {"e_grid": None, "v_before": None, "v_after": None, "rise": None, "q_visc_end": None,
                    "fault": dict.fromkeys(("PCC V1", "PCC phase RMS, mean of 3", "PCC phase RMS, lowest")),
                    "note": "no grid EMF in 0.80-1.15 gives V_pcc = 0.97 before the activation",
                    "rise_bound_current_limit": 4 * 10.0 * 1.5 / (grid.get("scr", 7.14) * 500.0)}
        p = cases.visc_plant(4, vp, activate=False, e_grid=e, **grid)
        r = p.run_offline(3.0, events=[(1.0, lambda q: q.set_mode(cases.visc_indices(4), "hd_visc"))],
                          record_every=10)
        r0 = cases.bare_plant(e_grid=e, **grid).run_offline(1.25, events=_fault_events(case.get("z_f", 0.0)),
                                                            record_every=5)
        net = cases.bare_plant(e_grid=e, **grid).net
        z2 = net.z_fault_shunt() - net.z0  # the passive network's Z2 (= its Z1: converters are current sources)
    v_before, v_after = float(r["v_pcc"][r["t"] < 1.0][-1]), float(r["v_pcc"][-1])
    f = _during(r0)
    ph = r0["v_pcc_ph"][f].mean(axis=0)
    return {"e_grid": e, "v_before": v_before, "v_after": v_after, "rise": v_after - v_before,
            "q_visc_end": [float(x) for x in r["q_wt"][-1, cases.visc_indices(4)]],
            "fault": {"PCC V1": float(r0["v_pcc"][f].mean()), "PCC phase RMS, mean of 3": float(ph.mean()),
                      "PCC phase RMS, lowest": float(ph.min())},
            "rise_bound_current_limit": 4 * 10.0 * 1.5 / (grid.get("scr", 7.14) * 500.0),
            # V1/V_pre of a bolted SLG fault at the PCC with passive sources only: (Z2 + Z0)/(Z1 + Z2 + Z0)
            "v1_passive_ratio": float(abs((z2 + net.z0) / (2 * z2 + net.z0))), "z2": [z2.real, z2.imag],
            "z0": [net.z0.real, net.z0.imag]}


def _grid_emf(error) -> float | None:
    """The root of ``error`` (brentq): on the report's bracket 0.85-1.1 first, else on the first sign
    change of a 0.05 grid over 0.80-1.15 (a plant controller at its limit can hold V_pcc above 0.97 at
    0.85); None if there is none."""
    def root(a: float, b: float) -> float | None:
        try:
            e = brentq(error, a, b, xtol=1e-4)
        except ValueError:
            return None
        return e if abs(error(e)) < 2e-3 else None  # not a jump where the load flow stops solving

    e = root(0.85, 1.1)
    if e is not None:
        return e
    es = np.arange(0.80, 1.1501, 0.05)
    vals = [error(e) for e in es]
    for k in range(len(es) - 1):
        if vals[k] * vals[k + 1] < 0 and (e := root(es[k], es[k + 1])) is not None:
            return e
    return None


F9_T_END, F9_N_MAX = 5.0, 8  # the full report's 5 s runs; n searched in 0..8 (report --quick's range)


def eval_f9(changes: dict) -> dict:
    """F9 as report/exp_weak.py: SCR 7.14 -> 1.51 at 1 s with n SDViSCs of cluster 3; with 3, the state
    and when V_pcc leaves the band for good (F9.a, F9.d); the fewest n that are stable (F9.c)."""
    plant_ch, visc, _ = _split(changes)
    runs: dict[int, object] = {}

    def state(n: int):
        if n not in runs:
            with patched(plant_ch):
                p = cases.visc_plant(n, visc_params=ViscParams(**visc))
            with np.errstate(all="ignore"):
                r = p.run_offline(F9_T_END, events=[(1.0, lambda q: q.set_scr(1.51))], record_every=10)
            runs[n] = (of_run(r, 1.0), r["t"], r["v_pcc"])
        return runs[n][0]

    s3 = state(3)
    b = smallest_sufficient(lambda n: state(n).stable, 0, F9_N_MAX)
    t3, v3 = runs[3][1], runs[3][2]
    return {"state_3": s3.state, "stable_3": s3.stable, "t_away_3": s3.t_away, "v_min_3": s3.v_min,
            "v_end_3": s3.v_end, "n_stable": b.value, "n_evaluations": b.evaluations,
            "trace_3": {"t": t3[::5].round(3).tolist(), "v_pcc": np.round(v3[::5], 4).tolist()}}


C1_T_PLUG, C1_T_END, C1_WT = 1.2, 3.2, 0  # wt1_1 (cluster 1's first turbine) at 1.2 s, as the scenario


def eval_c1(changes: dict) -> dict:
    """C1.b offline: the full farm (SC in service, as PlantParams() the network plant uses), turbine
    wt1_1 to the continuous ViSC law (hd_visc, H 3 s as the scenario) at 1.2 s; settling of |i| and
    the terminal |V| as report/exp_cyber.py measures it (within 0.02 p.u. of their mean over the last 0.3 s)."""
    plant_ch, visc, case = _split(changes)
    pp = _apply(PlantParams(), plant_ch)
    pp.visc_params = ViscParams(**{"h": 3.0, **visc})
    p = Plant(pp)
    if case.get("p_before_zero"):
        p.set_power_ref([C1_WT], p=0.0)
        p.reinitialise()
    r = p.run_offline(C1_T_END, events=[(C1_T_PLUG, lambda q: q.set_mode([C1_WT], "hd_visc"))], record_every=3)
    t, i, v = r["t"], r["i_wt"][:, C1_WT], r["v_wt"][:, C1_WT]  # what the paper names: current and voltage
    out = {}
    for band in (0.02, 0.05):
        out[f"settle band {band:g}"] = max(settle_time(t, i, C1_T_PLUG, C1_T_END, band),
                                           settle_time(t, v, C1_T_PLUG, C1_T_END, band))
    out["p_before_after"] = (float(r["p_wt"][t < C1_T_PLUG][-1, C1_WT]), float(r["p_wt"][-1, C1_WT]))
    return out


# ------------------------------------------------------------------------------------- the claims
@dataclass(frozen=True)
class Claim:
    id: str
    text: str
    paper: float
    unit: str
    group: str  # which evaluation it reads (several claims share one: F8.a/F8.c, F9.a/c/d)
    value: object  # result dict -> the judged number (None: does not happen)
    judge: object  # number -> "yes" / "partly" / "no" (the report's rule)
    towards: object  # result dict -> distance to the paper (smaller = closer; for the corner)
    measures: tuple = ()  # alternative measures of the same run (which bus / quantity): ambiguity rows


def _rel(x, paper):
    return abs(x - paper) if x is not None else float("inf")


GROUPS = {"F6.d": (eval_f6d, F6D_PARAMS), "F7.b": (eval_f7b, F7B_PARAMS), "F8": (eval_f8, F8_PARAMS),
          "F9": (eval_f9, F9_PARAMS), "C1.b": (eval_c1, C1_PARAMS)}
F6D_MEASURES = ("PCC V1", "PCC phase RMS, mean of 3", "PCC phase RMS, lowest")
CLAIMS = (
    Claim("F6.d", "SLG fault: the SDViSC's residual voltage is about 0.6 p.u. (its own terminal, positive sequence, "
          "as report F6 judges it)", 0.6, "p.u.", "F6.d", lambda r: r["terminal V1"], lambda x: close_to(x, 0.6),
          lambda r: _rel(r["terminal V1"], 0.6), tuple((m, (lambda r, m=m: r[m])) for m in F6D_MEASURES)),
    Claim("F7.b", "with the SC the farm loses stability when the SCR decreases to 1.58", 1.58, "SCR", "F7.b",
          lambda r: r["boundary"], lambda x: "no" if x is None else close_to(x, 1.58), lambda r: _rel(r["boundary"], 1.58)),
    Claim("F8.a", "4 SDViSCs activated at 1 s raise V_pcc from 0.97 to 1.02 p.u. (judged on the rise, +0.05)", 0.05,
          "p.u.", "F8", lambda r: r["rise"],
          lambda x: "no" if x is None else change_close_to(0.97, 0.97 + x, 0.97, 1.02),
          lambda r: _rel(r["rise"], 0.05)),
    Claim("F8.c", "without SDViSCs V_pcc drops to 0.4 p.u. during the SLG fault (the faulted phase's RMS, as report "
          "F8 reads it)", 0.4, "p.u.", "F8", lambda r: r["fault"]["PCC phase RMS, lowest"],
          lambda x: "no" if x is None else close_to(x, 0.4), lambda r: _rel(r["fault"]["PCC phase RMS, lowest"], 0.4),
          tuple((m, (lambda r, m=m: r["fault"][m])) for m in F6D_MEASURES[:2])),
    Claim("F9.d", "SCR 7.14 -> 1.51 with 3 SDViSCs: stable until ~3 s, then leaves the nominal point (F9.a: finally "
          "unstable)", 3.0, "s", "F9", lambda r: r["t_away_3"], lambda x: "no" if x is None else close_to(x, 3.0),
          lambda r: (_rel(r["t_away_3"], 3.0), r["v_min_3"])),
    Claim("F9.c", "SDViSCs needed at SCR 1.51: 4 (3 are not enough)", 4.0, "SDViSCs", "F9", lambda r: r["n_stable"],
          lambda x: "no" if x is None else close_to(x, 4.0), lambda r: (_rel(r["n_stable"], 4.0), r["v_min_3"])),
    Claim("C1.b", "a plugged SDViSC's currents and voltages settle within ~0.1 s (offline analogue: continuous law, "
          "no network)", 0.1, "s", "C1.b", lambda r: r["settle band 0.02"], lambda x: close_to(x, 0.1),
          lambda r: _rel(r["settle band 0.02"], 0.1), (("band 0.05 p.u.", lambda r: r["settle band 0.05"]),)),
)


def _fmt(x) -> str:
    return "—" if x is None else f"{x:.3f}" if isinstance(x, float) else str(x)


CASE_DEFAULTS = {"z_f": 0.0, "p_before_zero": False}


def _is_default(changes: dict) -> bool:
    """Whether ``changes`` sets every value to the default it already has (then the default run is reused)."""
    plant_ch, visc, case = _split(changes)
    pp, vp = PlantParams(), ViscParams()
    return (all(getattr(pp if k.split(".")[0] == "plant" else getattr(pp, k.split(".")[0]), k.split(".", 1)[1]) == v
                for k, v in plant_ch.items())
            and all(getattr(vp, k) == v for k, v in visc.items())
            and all(k in CASE_DEFAULTS and CASE_DEFAULTS[k] == v for k, v in case.items()))


def sweep_group(group: str, log) -> dict:
    """Every variation of the group's parameters, evaluated once each: {"default": r, param: {label: r}}."""
    evaluate, params = GROUPS[group]
    t0 = time.time()
    out = {"default": evaluate({})}
    log(f"{group}: default done ({time.time() - t0:.1f} s)")
    for prm in params:
        out[prm.name] = {}
        for label, ch in prm.changes.items():
            out[prm.name][label] = out["default"] if _is_default(ch) else evaluate(ch)
        log(f"{group}: {prm.name} done ({time.time() - t0:.1f} s)")
    return out


def corner(claim: Claim, group_runs: dict) -> tuple[dict, dict]:
    """Each range parameter at whichever end (or the default) brings the claim closest to the paper."""
    _, params = GROUPS[claim.group]
    changes, chosen = {}, {}
    base = claim.towards(group_runs["default"])
    for prm in params:
        if prm.kind != RANGE:
            continue
        best_label, best = None, base
        for label, r in group_runs[prm.name].items():
            d = claim.towards(r)
            if d < best:
                best_label, best = label, d
        if best_label is not None:
            chosen[prm.name] = best_label
            changes.update(prm.changes[best_label])
    return changes, chosen


def summarise(claim: Claim, group_runs: dict, corner_result: dict | None, corner_chosen: dict) -> dict:
    _, params = GROUPS[claim.group]
    default = claim.value(group_runs["default"])
    rows = []
    for prm in params:
        values = {label: claim.value(r) for label, r in group_runs[prm.name].items()}
        rows.append({"parameter": prm.name, "kind": prm.kind, "default": prm.default, "source": prm.source,
                     "changes": prm.changes, "values": values,
                     "verdicts": {k: claim.judge(v) for k, v in values.items()},
                     "reaches_within_10pct": [k for k, v in values.items() if claim.judge(v) == "yes"]})
    for name, measure in claim.measures:  # another bus / quantity of the same default run
        v = measure(group_runs["default"])
        rows.append({"parameter": f"measured as: {name}", "kind": AMBIGUITY, "default": "as the report",
                     "source": "which bus / quantity the paper's figure shows is not stated", "changes": {},
                     "values": {name: v}, "verdicts": {name: claim.judge(v)},
                     "reaches_within_10pct": [name] if claim.judge(v) == "yes" else []})
    out = {"id": claim.id, "claim": claim.text, "paper": claim.paper, "unit": claim.unit, "default": default,
           "default_verdict": claim.judge(default), "parameters": rows}
    if corner_result is not None:
        v = claim.value(corner_result)
        out["best_corner"] = {"chosen": corner_chosen, "value": v, "verdict": claim.judge(v)}
    candidates = [(f"{r['parameter']}: {k}", v) for r in rows if r["kind"] == RANGE for k, v in r["values"].items()]
    if corner_result is not None:
        candidates.append(("best corner", out["best_corner"]["value"]))
    by, v = min(candidates, key=lambda c: _rel(c[1], claim.paper), default=("default", default))
    if _rel(default, claim.paper) <= _rel(v, claim.paper):
        by, v = "default", default
    out["best_defensible"] = {"by": by, "value": v, "verdict": claim.judge(v)}
    ranged = [r for r in rows if r["kind"] == RANGE and r["reaches_within_10pct"]]
    out["reached_with_a_defensible_range_value"] = bool(ranged) or (
        corner_result is not None and out["best_corner"]["verdict"] == "yes")
    out["reached_only_by_an_ambiguity"] = [f"{r['parameter']}: {k}" for r in rows if r["kind"] == AMBIGUITY
                                           for k in r["reaches_within_10pct"]]
    return out


# ------------------------------------------------------------------------------------- the figures
def figure(summary: dict, path: Path) -> None:
    """A tornado: per row the claim's number at each tried value (range ends: blue low, red high;
    alternatives: green), the default as a vertical line, the paper's value and its ±10 % shaded;
    values for which the number does not exist (n/a) are named under the row, not plotted."""
    rows = summary["parameters"] + ([{"parameter": "best corner (all range ends towards the paper)", "kind": RANGE,
                                      "values": {"corner": summary["best_corner"]["value"]}}]
                                    if "best_corner" in summary else [])
    paper, default = summary["paper"], summary["default"]
    finite = [v for r in rows for v in r["values"].values() if v is not None] + [paper] + (
        [default] if default is not None else [])
    lo, hi = min(finite), max(finite)
    pad = 0.08 * (hi - lo or 1.0)
    fig, ax = plt.subplots(figsize=(9.0, 1.4 + 0.5 * len(rows)))
    ax.axvspan(0.9 * paper, 1.1 * paper, color="0.9", zorder=0, label="paper ±10 %")
    ax.axvline(paper, color="k", lw=1.2, label=f"paper {paper:g} {summary['unit']}")
    if default is not None:
        ax.axvline(default, color="C2", ls="--", lw=1.0, label=f"testbed default {default:.3g}")
    else:
        ax.plot([], [], " ", label="testbed default: n/a")
    for y, r in enumerate(reversed(rows)):
        items = list(r["values"].items())
        xs = [v for _, v in items if v is not None] + ([default] if default is not None else [])
        if xs:
            ax.plot([min(xs), max(xs)], [y, y], color="0.6", lw=4, alpha=0.5, solid_capstyle="butt")
        missing = []
        for j, (label, v) in enumerate(items):
            color = "C2" if r["kind"] == AMBIGUITY else ("C0" if j == 0 and len(items) > 1 else "C3")
            if v is None:
                missing.append(label)
                continue
            ax.plot([v], [y], "o", color=color, ms=6)
            ax.annotate(label, (v, y), textcoords="offset points", xytext=(0, -11 if j == 0 and len(items) > 1 else 5),
                        ha="center", fontsize=6.5, color=color)
        if missing:
            ax.annotate("n/a: " + "; ".join(missing), (lo - pad, y), textcoords="offset points", xytext=(2, -12),
                        ha="left", fontsize=6.5, color="0.35", style="italic")
    ax.set_yticks(range(len(rows)))
    ax.set_yticklabels([("* " if r["kind"] == AMBIGUITY else "") + r["parameter"] for r in reversed(rows)], fontsize=7)
    ax.set_xlim(lo - pad, hi + pad)
    ax.set_ylim(-0.8, len(rows) - 0.4)
    ax.set_xlabel(f"{summary['id']} [{summary['unit']}]")
    ax.set_title(f"{summary['id']}: {summary['claim']}", fontsize=8, loc="left", wrap=True)
    ax.grid(alpha=0.3, axis="x")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.text(0.01, 0.005, "blue: low end, red: high end of a source range; green, *: an alternative the paper leaves "
             "open (not a range); n/a: the number does not exist there. benchmarks/claim_sensitivity.py", fontsize=6.5,
             style="italic")
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


def figure_f9_traces(raw: dict, path: Path) -> list[str]:
    """V_pcc with 3 SDViSCs at SCR 1.51 (F9.a, F9.d) for the default and every variation that changes
    the 3-SDViSC state; the paper's 3 s and the 0.9-1.1 band marked."""
    fig, ax = plt.subplots(figsize=(9.0, 4.2))
    shown = []
    base = raw["default"]["state_3"]
    variants = [("default", raw["default"])] + [(f"{prm} {label}", r) for prm, runs in raw.items() if prm != "default"
                                                 for label, r in runs.items() if r["state_3"] != base]
    for k, (label, r) in enumerate(variants):
        tr = r["trace_3"]
        ax.plot(tr["t"], tr["v_pcc"], lw=1.6 if k == 0 else 0.8, color="k" if k == 0 else f"C{k % 10}",
                label=f"{label}: {r['state_3']}")
        shown.append(label)
    for v in (0.9, 1.1):
        ax.axhline(v, color="0.5", ls=":", lw=0.8)
    ax.axvline(3.0, color="C3", ls="--", lw=0.9, label="paper: 3 SDViSCs stable until ~3 s")
    ax.set_xlabel("t [s] (SCR 7.14 -> 1.51 at 1 s, 3 SDViSCs of cluster 3)")
    ax.set_ylabel("|V_pcc| [p.u.]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=6.5, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return shown


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="benchmarks/measured/claim-sensitivity")
    ap.add_argument("--date", default=datetime.date.today().isoformat())
    ap.add_argument("--only", default="", help="comma-separated groups: F6.d, F7.b, F8, F9, C1.b")
    ap.add_argument("--commit", default=None, help="the code's commit, for the record (default: git rev-parse "
                    "HEAD here, marked if plant/, report/ or sdc_unit/ have uncommitted changes)")
    ap.add_argument("--redraw", action="store_true", help="only draw the figures again from the JSON in --out")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.redraw:
        data = json.loads((out / f"claim-sensitivity-{args.date}.json").read_text())
        for s in data["claims"]:
            figure(s, out / s["figure"])
        if "F9" in data["raw"]:
            figure_f9_traces(data["raw"]["F9"], out / f"f9d-traces-{args.date}.png")
        return 0
    groups = [g for g in GROUPS if not args.only or g in args.only.split(",")]
    t_start = time.time()

    def log(msg: str) -> None:
        print(f"[{time.time() - t_start:6.1f} s] {msg}", file=sys.stderr, flush=True)

    runs, result = {}, {"date": args.date, "commit": args.commit or _commit(),
                        "command": "PYTHONPATH=. .venv/bin/python benchmarks/claim_sensitivity.py",
                        "settings": {"f7": {"scr_range": F7_RANGE, "xtol": F7_XTOL, "t_end_s": F7_T_END},
                                     "f9": {"t_end_s": F9_T_END, "n_max": F9_N_MAX},
                                     "c1": {"t_plug_s": C1_T_PLUG, "t_end_s": C1_T_END, "turbine": C1_WT}},
                        "claims": [], "raw": {}}
    for g in groups:
        runs[g] = sweep_group(g, log)
    for claim in CLAIMS:
        if claim.group not in runs:
            continue
        changes, chosen = corner(claim, runs[claim.group])
        evaluate, _ = GROUPS[claim.group]
        corner_result = evaluate(changes) if changes else None
        log(f"{claim.id}: corner {chosen}")
        s = summarise(claim, runs[claim.group], corner_result, chosen)
        result["claims"].append(s)
        name = f"{claim.id.lower().replace('.', '')}-{args.date}.png"
        figure(s, out / name)
        s["figure"] = name
        print(f"{claim.id}: paper {claim.paper:g}, default {_fmt(s['default'])} ({s['default_verdict']}), corner "
              f"{_fmt(s.get('best_corner', {}).get('value'))}, best defensible {_fmt(s['best_defensible']['value'])} "
              f"({s['best_defensible']['by']}), reached with a range value: "
              f"{s['reached_with_a_defensible_range_value']}, by an alternative: {s['reached_only_by_an_ambiguity']}")
    if "F9" in runs:
        name = f"f9d-traces-{args.date}.png"
        figure_f9_traces(runs["F9"], out / name)
        next(c for c in result["claims"] if c["id"] == "F9.d")["figure_traces"] = name
    result["raw"] = {g: _jsonable(r) for g, r in runs.items()}
    result["wall_s"] = round(time.time() - t_start, 1)
    path = out / f"claim-sensitivity-{args.date}.json"
    path.write_text(json.dumps(_jsonable(result), indent=1) + "\n")
    log(f"wrote {path} and {len(result['claims'])} figures")
    return 0


def _commit() -> str:
    def git(*a: str) -> str:
        return subprocess.run(["git", *a], capture_output=True, text=True, cwd=Path(__file__).parent).stdout.strip()
    head = git("rev-parse", "HEAD") or "unknown"
    return head + (" + uncommitted changes" if git("status", "--porcelain", "--", "plant", "report", "sdc_unit")
                   else "")


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    return x


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
