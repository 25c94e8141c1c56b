"""The weak-grid evaluations of the claim sensitivity study, each as the report measures it
(report/exp_weak.py, report/f7_second_look.py, report/f7_mechanism.py, report/stability.py):

* F7 (Fig. Compare_Weak): per case (none, SC, the SDViSC) the step boundary — SCR 7.14 -> s at 1 s,
  bisection on s over the report's [1.0, 4.0] (continued over [4.0, 7.0] if 4.0 itself is not
  stable) to the report's full tolerance 0.02, 4 s runs, "stable" by report/stability.py — and the
  mechanism of the loss (f7_mechanism.mechanism on the run just below it); or, with ``case.ramp``,
  the slow-ramp boundary and its mechanism.
* F9 (Fig. study2_Weak_noVSC): SCR 7.14 -> 1.51 at 1 s with n SDViSCs of cluster 3 (5 s runs, n
  searched in 0..16 as the full report); with 3, the state and when WT1_CS1 (turbine 0, the
  caption's) leaves the band for good (F9.d), the PCC beside it; the fewest n that are stable (F9.c).

Case options: ``ramp`` (the slow ramp instead of the step), ``ki_per_scr`` (the plant controller's
k_i set to this x the run's post-event SCR: structure.KI_RULE)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

import plant.cases as cases
from benchmarks.sensitivity.common import patched, split
from benchmarks.sensitivity.structure import SCR_DEFAULT
from report import f7_mechanism as mech
from report.boundary import smallest_sufficient, threshold
from report.exp_weak import F9_SCR, SCR_RANGE, T_EVENT, WT1_CS1, f7_search_settings, f9_settings
from report.f7_second_look import ramp_boundary
from report.stability import LAST_S, of_run, time_away
from sdc_unit.params import ViscParams

F7_T_END, F7_XTOL = f7_search_settings(False)  # the full report's: 4 s runs, bisection to 0.02
F7_SCR_ABOVE = (SCR_RANGE[1], 7.0)  # searched when the report's upper end is itself not stable
F9_T_END, F9_N_MAX = f9_settings(False)  # 5 s runs, n in 0..16
F9_N_MAX_RAMP = 8  # the ramp's runs are ~20x longer: n in 0..8 (report --quick's range; F9's n is 5 by the step)
RAMP_RATE = mech.ramp_settings(False)  # 0.025 SCR/s
F7_CASES = ("none", "SC", "SDViSC")  # report/exp_weak.py F7_CONFIGS without the friction variant (its own row)


def _maker(case: str, visc: dict):
    if case == "none":
        return cases.bare_plant
    if case == "SC":
        return cases.sc_plant
    return lambda: cases.comparison_visc_plant(visc_params=ViscParams(**visc))


def _plant(case: str, plant_ch: dict, visc: dict, opts: dict, scr: float):
    with patched(plant_ch):
        p = _maker(case, visc)()
    if opts.get("ki_per_scr") and p.wpp is not None:
        p.wpp.p = replace(p.wpp.p, k_i=ki_at(opts, scr))
    return p


def ki_at(opts: dict, scr: float) -> float:
    """The re-tuned k_i at ``scr`` (structure.KI_RULE): ki_per_scr x SCR x (SCR/7.14)^(ki_power - 1)."""
    return opts["ki_per_scr"] * scr * (scr / SCR_DEFAULT) ** (opts.get("ki_power", 1.0) - 1.0)


def _record(r: dict) -> dict:
    return {"t": r["t"], "v_pcc": r["v_pcc"], "v_wt": r.get("v_wt")}


def f7_case_step(case: str, plant_ch: dict, visc: dict, opts: dict) -> dict:
    """The step boundary of ``case`` and the mechanism of the loss just below it."""
    runs: dict[float, dict] = {}

    def run(scr: float) -> dict:
        if scr not in runs:
            p = _plant(case, plant_ch, visc, opts, scr)
            with np.errstate(all="ignore"):
                r = p.run_offline(F7_T_END, events=[(T_EVENT, lambda q: q.set_scr(scr))], record_every=10)
            runs[scr] = _record(r)
        return runs[scr]

    def stable(scr: float) -> bool:
        return of_run(run(scr), T_EVENT).stable

    xtol = opts.get("xtol", F7_XTOL)
    b = threshold(stable, *SCR_RANGE, xtol)
    searched = SCR_RANGE
    if b.value is None and not stable(SCR_RANGE[1]):
        b = threshold(stable, *F7_SCR_ABOVE, xtol)
        searched = F7_SCR_ABOVE
    out = {"boundary": b.value, "bracket": b.bracket, "searched": searched, "xtol": xtol, "evaluations": b.evaluations,
           "note": b.note}
    if b.bracket:
        lo, hi = b.bracket
        r = runs[lo]
        out["below"] = {"scr": lo, "state": of_run(r, T_EVENT).describe(),
                        "mechanism": mech.mechanism(r["t"], r["v_pcc"], T_EVENT + 1.0)}
        out["above"] = {"scr": hi, "state": of_run(runs[hi], T_EVENT).describe()}
    return out


def f7_case_ramp(case: str, plant_ch: dict, visc: dict, opts: dict) -> dict:
    """The slow-ramp boundary of ``case`` (report/f7_mechanism.py) and the mechanism of the loss."""
    wpp = "legacy" if plant_ch == {"wpp.legacy": True} else "IEC"
    if not visc and (not plant_ch or wpp == "legacy") and not opts.get("ki_per_scr"):
        r = ramp_boundary(case, RAMP_RATE, wpp)  # the report's own run (cached there; its CONFIGS keys are these)
        how = f"report.f7_second_look.ramp_boundary({case!r}, {RAMP_RATE}, {wpp!r})"
    else:
        r = mech.ramp_run(_plant(case, plant_ch, visc, opts, 1.5), RAMP_RATE)
        how = "report.f7_mechanism.ramp_run on the changed plant"
    loss = r["loss_scr"]
    m = ("stable to the floor" if r["loss_t"] is None
         else mech.mechanism(r["t"], r["v_pcc"], r["loss_t"] + LAST_S, r.get("v_wt")))
    return {"boundary": loss, "ramp": True, "rate": RAMP_RATE, "loss_t": r["loss_t"], "how": how,
            "below": {"scr": loss, "mechanism": m}}


def _affected(plant_ch: dict, visc: dict, opts: dict) -> set[str]:
    """The cases a change can move: the SC's parameters only the SC case, the ViSC law's only the
    SDViSC case (the others are the default's runs, not run again)."""
    parts = {k.split(".")[0] for k in plant_ch} | ({"visc"} if visc else set()) | (set(opts) - {"ramp", "xtol"})
    if parts == {"condenser"}:
        return {"SC"}
    if parts == {"visc"}:
        return {"SDViSC"}
    return set(F7_CASES)


_DEFAULTS: dict[bool, dict] = {}


def _default(ramp: bool) -> dict:
    if ramp not in _DEFAULTS:
        _DEFAULTS[ramp] = eval_f7({"case.ramp": True} if ramp else {})
    return _DEFAULTS[ramp]


def eval_f7(changes: dict) -> dict:
    """F7.a/b/c: each case's boundary (step, or ramp with ``case.ramp``)."""
    plant_ch, visc, opts = split(changes)
    one = f7_case_ramp if opts.get("ramp") else f7_case_step
    todo = _affected(plant_ch, visc, opts)
    base = None if todo == set(F7_CASES) else _default(bool(opts.get("ramp")))
    out = {c: one(c, plant_ch, visc, opts) if c in todo else {**base[c], "same_as_default": True} for c in F7_CASES}
    out["boundaries"] = {c: out[c]["boundary"] for c in F7_CASES}
    return out


# ---------------------------------------------------------------------------------------------- F9
def _f9_ramp_events(scr_to: float) -> tuple[list, float]:
    """A step to RAMP_FROM at 1 s, then RAMP_DT steps of RAMP_RATE x RAMP_DT down to ``scr_to``: the
    events and the time ``scr_to`` is reached."""
    events = [(T_EVENT, lambda q: q.set_scr(mech.RAMP_FROM))]
    t, s = mech.RAMP_START, mech.RAMP_FROM
    while s > scr_to + 1e-9:
        s = max(s - RAMP_RATE * mech.RAMP_DT, scr_to)
        events.append((t, lambda q, s=s: q.set_scr(s)))
        t += mech.RAMP_DT
    return events, t - mech.RAMP_DT


def eval_f9(changes: dict) -> dict:
    """F9 as report/exp_weak.py (see the module's docstring); ``case.ramp``: the SCR reaches 1.51 by
    the slow ramp and is held F9_T_END - 1 s; times are then counted from reaching it, plus 1 s."""
    plant_ch, visc, opts = split(changes)
    runs: dict[int, tuple] = {}
    if opts.get("ramp"):
        events, t_reach = _f9_ramp_events(F9_SCR)
        t_end, t_event = t_reach + F9_T_END - T_EVENT, t_reach
    else:
        events, t_end, t_event = [(T_EVENT, lambda q: q.set_scr(F9_SCR))], F9_T_END, T_EVENT

    def state(n: int):
        if n not in runs:
            with patched(plant_ch):
                p = cases.visc_plant(n, visc_params=ViscParams(**visc))
            if opts.get("ki_per_scr") and p.wpp is not None:
                p.wpp.p = replace(p.wpp.p, k_i=ki_at(opts, F9_SCR))
            with np.errstate(all="ignore"):
                r = p.run_offline(t_end, events=list(events), record_every=10)
            runs[n] = (of_run(r, t_event), r["t"], r["v_pcc"], r["v_wt"][:, WT1_CS1], r["v_wt"][:, cases.visc_indices(n)]
                       if n else None)
        return runs[n][0]

    s3 = state(3)
    b = smallest_sufficient(lambda n: state(n).stable, 0, F9_N_MAX_RAMP if opts.get("ramp") else F9_N_MAX)
    _, t3, v3, wt1, v_visc = runs[3]
    shift = T_EVENT - t_event  # 0 for the step
    t_wt1 = time_away(t3, wt1, t_event)
    keep = t3 >= t_event - 1.0
    return {"state_3": s3.state, "stable_3": s3.stable, "describe_3": s3.describe(),
            "t_away_wt1_3": None if t_wt1 is None else t_wt1 + shift,
            "t_away_pcc_3": None if s3.t_away is None else s3.t_away + shift,
            "v_min_3": s3.v_min, "v_end_3": s3.v_end, "v_wt1_end_3": float(wt1[-1]),
            "v_visc_end_3": [float(x) for x in v_visc[-1]],
            "n_stable": b.value, "n_evaluations": b.evaluations, "ramp": bool(opts.get("ramp")),
            "trace_3": {"t": (t3[keep][::5] + shift).round(3).tolist(), "v_pcc": np.round(v3[keep][::5], 4).tolist(),
                        "v_wt1": np.round(wt1[keep][::5], 4).tolist()}}
