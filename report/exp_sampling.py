"""B2 (beyond the paper, issue 9): the SDC's sampling period swept -- offline.

F1's case (SLG fault at the PCC 1.0–1.3 s, four SDViSCs, the full farm) co-simulated in one process
(plant/cosim.py) with the SDC sampled at Ts for each discretisation of docs/sdc.md: Tustin (float64),
trapezoid-cumulative in float32 and in float64 (F2's method), forward Euler (float64). The plant
steps at most PLANT_STEP_MAX_S (Ts / m with m = ceil(Ts / 0.25 ms)); the SDC's output is held over
the m plant steps of a sample, in the paper's loop (the answer to a sample drives the plant until
the next sample; remote_apply = v_ref, the SDC closes the inner current loop). Each run is compared
with the HD reference (plant/hd_reference.py: the continuous law with the SDC's own parameters at
50 µs) at its own sample instants."""

from __future__ import annotations

import math

import numpy as np

from plant import hd_reference
from plant.cosim import FaultCase, compare, run_sdc
from report import figures
from report.beyond import ACCEPT_PCT, UNSTABLE_CRITERION, crossing, instability, worst_pct
from report.exp_sdc import RMS_PARTLY, RMS_YES
from report.registry import MEASURED, Context, Experiment, Finding, PaperClaim

TS_MS = (0.25, 0.5, 0.67, 1.0, 2.0, 5.0)
QUICK_TS_MS = (0.25, 0.67, 2.0, 5.0)
PAPER_TS_MS = 0.67
PLANT_STEP_MAX_S = 0.25e-3
METHODS = (("tustin", "float64", "Tustin"), ("trapezoid_cumulative", "float32", "trapezoid-cumulative float32"),
           ("trapezoid_cumulative", "float64", "trapezoid-cumulative float64"), ("euler", "float64", "forward Euler"))
CONVENTIONAL = ("trapezoid-cumulative float32", "trapezoid-cumulative float64", "forward Euler")

CLAIMS = (
    PaperClaim("B2.a", "The Tustin SDC at a moderate sampling period, Ts = 0.67 ms, performs as well as the HD ViSC "
               "(Section II-C, IV-B)", "0.67 ms: no obvious deterioration"),
    PaperClaim("B2.b", "Conventional integration rules (Euler, trapezoidal) need smaller sampling periods than the Tustin "
               "transformation to perform the same control (Section II-C)", "smaller Ts than Tustin (no number)"),
    PaperClaim("B2.c", "Largest swept Ts at which each discretisation stays within 5 % of the HD ViSC (offline), "
               "and where it stops", "not stated", beyond=True),
)


def case_for(ts_ms: float, t_end_s: float) -> FaultCase:
    """F1's case with the SDC at ``ts_ms``, the plant at Ts / ceil(Ts / PLANT_STEP_MAX_S)."""
    ts = ts_ms * 1e-3
    return FaultCase(t_end_s=t_end_s, step_s=ts, plant_steps_per_sample=max(1, math.ceil(ts / PLANT_STEP_MAX_S - 1e-6)))


def fault_phase_ms(case: FaultCase) -> float:
    """How long after the last sample the fault is applied (the plant step nearest t_fault) [ms]."""
    k = int(round(case.t_fault_s / case.plant_step_s))
    return (k % case.plant_steps_per_sample) * case.plant_step_s * 1e3


def acceptable_limits(table: dict[str, list[dict]]) -> dict:
    """Per method: the crossing of "not acceptable" (worst > ACCEPT_PCT, or unstable) along Ts."""
    return {name: crossing([p["ts_ms"] for p in pts], [p["worst_pct"] > ACCEPT_PCT or p["unstable"] is not None
                                                       for p in pts])
            for name, pts in table.items()}


def verdict_needs_smaller_ts(lims: dict, reference: str = "Tustin", others=CONVENTIONAL) -> tuple[str, str]:
    """B2.b: yes if the reference is acceptable at a larger Ts than every conventional rule, partly if
    than some, no if than none (a method acceptable over the whole sweep counts at its largest Ts)."""
    ref = lims[reference].last_good
    if ref is None:
        return "no", f"{reference} is not acceptable at any swept Ts"
    larger = [o for o in others if lims[o].last_good is None or lims[o].last_good < ref]
    verdict = "yes" if len(larger) == len(others) else "partly" if larger else "no"
    return verdict, (f"criterion: the largest acceptable Ts (worst ≤ {ACCEPT_PCT:g} % and stable) of {reference} "
                     f"above every conventional rule's: yes; above some: partly; above none: no. "
                     f"Smaller than {reference}'s: {', '.join(larger) or 'none'}")


def _b2(ctx: Context) -> dict[str, Finding]:
    t_end = 2.0 if ctx.quick else 3.0
    sweep = QUICK_TS_MS if ctx.quick else TS_MS
    table: dict[str, list[dict]] = {label: [] for *_, label in METHODS}
    phases = {}
    for ts_ms in sweep:
        case = case_for(ts_ms, t_end)
        hd = hd_reference.reference_on_samples(case)  # the 50 µs run is cached: one per event instants
        phases[ts_ms] = fault_phase_ms(case)
        for method, dtype, label in METHODS:
            r = hd_reference.on_samples(run_sdc(case, method=method, dtype=np.dtype(dtype)), case)
            cmp = compare(r, hd)
            why = instability(r["t"], r["v_pcc"][:, 0], hd["v_pcc"][:, 0], r["trips"], r["trip_t"])
            table[label].append({"ts_ms": ts_ms, "plant_steps_per_sample": case.plant_steps_per_sample,
                                 "pct": {q: c["rms_over_range_pct"] for q, c in cmp.items()},
                                 "worst_pct": worst_pct(cmp), "unstable": why})
    lims = acceptable_limits(table)
    ctx.numbers["ts_sweep"] = table
    ctx.numbers["acceptable_up_to_ms"] = {k: c.last_good for k, c in lims.items()}
    ctx.numbers["not_acceptable_from_ms"] = {k: c.first_bad for k, c in lims.items()}
    ctx.notes += [
        f"Offline: the plant steps Ts / m (m = ceil(Ts / {PLANT_STEP_MAX_S * 1e3:g} ms)), the SDC's output held over "
        "the m steps; each run against the HD reference (" + hd_reference.LABEL + ") at the run's sample instants. "
        "The paper's loop (no added delay), remote_apply = v_ref.",
        f"Acceptable = worst RMS deviation of |V_pcc|, Q, δ, E / HD range ≤ {ACCEPT_PCT:g} % over 0–{t_end:g} s, and "
        f"stable. {UNSTABLE_CRITERION}",
        "The fault is applied at the plant step nearest 1.0 s, asynchronous to the SDC's samples: it falls "
        + ", ".join(f"{phases[t]:.2f} ms" for t in sweep) + " after a sample at Ts = "
        + ", ".join(f"{t:g}" for t in sweep) + " ms (the longer the pre-fault reference is held into the fault, "
        "the larger the error: the curves need not be monotonic).",
    ]
    _figure(ctx, table, lims, t_end, phases)
    tustin = next(p for p in table["Tustin"] if p["ts_ms"] == PAPER_TS_MS)
    w = tustin["worst_pct"]
    verdict_a = "yes" if w <= RMS_YES and not tustin["unstable"] else "partly" if w <= RMS_PARTLY else "no"
    a = Finding(f"Tustin at {PAPER_TS_MS} ms: worst RMS deviation / HD range {w:.2f} %", verdict_a,
                f"criterion (F1's): ≤ {RMS_YES:g} % reproduced, ≤ {RMS_PARTLY:g} % partly; per quantity "
                + ", ".join(f"{q} {v:.2f} %" for q, v in tustin["pct"].items()), {"worst_pct": w})
    verdict_b, criterion = verdict_needs_smaller_ts(lims)
    b = Finding("largest acceptable Ts: " + ", ".join(f"{k} {_ms(c.last_good)}" for k, c in lims.items()), verdict_b,
                criterion + ". " + _evidence(table), ctx.numbers["acceptable_up_to_ms"])
    c = Finding("; ".join(f"{k}: {c.describe('acceptable', 'not', 'ms')}" for k, c in lims.items()), MEASURED,
                _evidence(table), {"acceptable_up_to_ms": ctx.numbers["acceptable_up_to_ms"],
                                   "not_acceptable_from_ms": ctx.numbers["not_acceptable_from_ms"]})
    return {"B2.a": a, "B2.b": b, "B2.c": c}


def _ms(x: float | None) -> str:
    return "none" if x is None else f"{x:g} ms"


def _evidence(table: dict[str, list[dict]]) -> str:
    def one(p):
        return f"{p['ts_ms']:g} ms {p['worst_pct']:.2f} %" + (f" ({p['unstable']})" if p["unstable"] else "")

    return "worst RMS / HD range: " + "; ".join(f"{k}: " + ", ".join(one(p) for p in pts) for k, pts in table.items())


def _figure(ctx: Context, table: dict, lims: dict, t_end: float, phases: dict[float, float]) -> None:
    fig, axes = figures.new(1, height_per_row=4.2, width=8.5)
    ax = axes[0, 0]
    styles = {"Tustin": ("k", "o", "-", 2.0), "trapezoid-cumulative float32": ("C0", "s", "--", 1.2),
              "trapezoid-cumulative float64": ("C2", "^", ":", 1.4), "forward Euler": ("C3", "D", "-.", 1.2)}
    for label, pts in table.items():
        color, marker, ls, lw = styles[label]
        ts = [p["ts_ms"] for p in pts]
        ax.plot(ts, [min(p["worst_pct"], 1e3) for p in pts], color=color, marker=marker, ls=ls, lw=lw, ms=5,
                mfc="none", label=f"{label} (acceptable up to {_ms(lims[label].last_good)})")
        bad = [p for p in pts if p["unstable"]]
        ax.plot([p["ts_ms"] for p in bad], [min(p["worst_pct"], 1e3) for p in bad], "x", color=color, ms=11, mew=2)
    ax.plot([], [], "kx", ms=9, mew=2, label="unstable (converter trip, divergence or oscillation)")
    ax.axhline(ACCEPT_PCT, color="C3", ls="--", lw=1.0, label=f"{ACCEPT_PCT:g} %: acceptable")
    ax.axhline(1.0, color="C3", ls=":", lw=0.8, label="1 % (F1's criterion)")
    ax.axvline(PAPER_TS_MS, color="0.5", lw=0.9, ls="-.", label=f"the paper's Ts = {PAPER_TS_MS} ms")
    for ts_ms, phase in phases.items():
        if phase > 0:
            y = next(p["worst_pct"] for p in table["Tustin"] if p["ts_ms"] == ts_ms)
            ax.annotate(f"fault {phase:.2f} ms after a sample\n(on a sample at the other Ts)", (ts_ms, y),
                        xytext=(ts_ms * 1.08, y * 0.45), fontsize=7, arrowprops={"arrowstyle": "-", "lw": 0.6})
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_ylim(0.1, 300)
    ts_all = sorted({p["ts_ms"] for pts in table.values() for p in pts})
    ax.set_xticks(ts_all)
    ax.set_xticklabels([f"{t:g}" for t in ts_all])
    ax.minorticks_off()
    ax.set_xlabel("SDC sampling period Ts [ms] (log scale)")
    ax.set_ylabel("worst RMS deviation / HD range [%]\n(|V_pcc|, Q, δ, E; log scale)")
    ax.legend(fontsize=7.5, loc="upper left")
    figures.save(ctx, fig, "b2_error_vs_ts",
                 f"Worst RMS deviation from the HD ViSC (% of its range, 0–{t_end:g} s) vs the SDC's Ts per discretisation, "
                 "F1's fault, plant/cosim.py, no added delay, v_ref. Tustin and trapezoid-cumulative float32/64 coincide "
                 "(the same linear map, ERRATA 5).",
                 prefix="Beyond the paper (offline): ")


B2 = Experiment("B2", "Sampling period sweep per discretisation", "— (beyond the paper)", "offline", CLAIMS,
                _b2, "", "Beyond the paper (issue 9), offline: F1's case in plant/cosim.py with the SDC at Ts = "
                "0.25–5 ms, Tustin, trapezoid-cumulative float32/float64 and forward Euler, each against the HD ViSC "
                "on the same plant step.")
