"""EMTW: F7 (the SCR below which the farm loses stability after a step at 1 s: no device, the SC, the four
SDViSCs of cluster 3) and F9 (SCR 7.14 → 1.51 with 3 and 4 SDViSCs) on the EMT backend (plant/emt/farm.py,
DPsim) beside the phasor plant, with the same stability criterion (report/stability.py) on the PCC's
positive-sequence voltage (one-cycle mean of the Park phasor).

The SCR step in EMT: the grid's Thevenin branch is the final SCR's, a parallel branch of the same X/R makes
it 7.14 until its breaker opens at 1 s, each pole at its current's zero. The rest of the farm is one
aggregated grid-following converter with the phasor turbine's control structure (plant/emt/gfl_farm.py: PLL,
|v| filter, DC link, current limit and FRT with reactive priority) behind the aggregated turbine
transformers and array cables, its Q* the plant controller's order (plant/wpp.py, the phasor plant's,
settled; the turbines' Q limitation at the aggregate's V_m); the devices driven every Ts (farm_run's
``ts``). The rows say how far the boundaries are apart and how each model loses stability just below its
own (``measured["below"]``: the phasor plant's turbines settle current-limited in a sag; the EMT
aggregate's PLL slips, an ideal current source with no modulation limit); the paper's reading of each EMT
value is in ``measured["printed"]`` for report/printed.py's count per model.

F7's SDViSC row of the paper is the comparison arrangement's one 40 MVA SDViSC at the onshore PCC; the EMT
farm arrangement has the four 10 MVA SDViSCs of cluster 3 (the phasor plant's F7net variant, NET_CASE),
compared with the phasor plant's search of the same case."""

from __future__ import annotations

import numpy as np

from plant.emt import frame
from plant.emt.farm import EmtFarm
from report import figures
from report.boundary import Boundary, threshold
from report.exp_weak import F9_SCR, f9_run, f9_settings
from report.registry import CONSISTENCY, Context, Experiment, Finding, PaperClaim
from report.stability import V_NORMAL, Stability, of_run, stability
from report.verdicts import close_to
from report.weak_cases import (
    NET_CASE,
    SCR_RANGE,
    T_EVENT,
    VIRTUAL_FRICTION_DEFAULT,
    f7_search_settings,
    search_boundary,
    visc_params,
)

FARM_MODEL = "gfl"  # the rest of the farm: one grid-following converter with the phasor turbine's controls
EXCHANGE = "ts"  # the devices driven every Ts (plant/emt/farm_run.py): the F7/F9 quantities as with every step
SCR_YES, SCR_PARTLY = 0.1, 0.3
SLIP_HZ = 1.0  # |PLL slip| over the last second above which the EMT aggregate has lost synchronism  # |EMT - phasor| boundary, SCR: yes (issue 40's goal), partly
CASES = {"none": {"n_visc": 0}, "SC": {"n_visc": 0, "with_sc": True},
         NET_CASE: {"n_visc": 4, "visc_params": visc_params(False)}}
PAPER = {"none": 2.04, "SC": 1.58}
QUICK_XTOL = 0.25  # SCR: the EMT searches' tolerance under --quick (6 runs each instead of 8; the full report
# uses F7's 0.02), to keep --quick within its 5 min


def emt_scr_run(case: dict, scr: float, t_end: float) -> dict:
    """One EMT run of ``case`` (EmtFarm keys) with the SCR step 7.14 → ``scr`` at 1 s; the SDViSCs active from
    the start (as the phasor plant's cases)."""
    m = EmtFarm(scr_after=scr, farm_model=FARM_MODEL, exchange=EXCHANGE, **case)
    events = [(T_EVENT, EmtFarm.scr_step)] + ([(0.0, EmtFarm.activate)] if case.get("n_visc") else [])
    with np.errstate(all="ignore"):
        r = m.run(t_end, events=events)
    v1 = np.abs(frame.positive_sequence(r["v_pcc"], r["spc"]))
    vt = np.abs(r["v_t"]) if r["v_t"].size else None
    n_sub = m.n_sub
    keep = slice(n_sub - 1, None, n_sub)  # every Ts, at the exchange's instants (r["t_ts"])
    out = {"t": r["t"][keep], "v_pcc": v1[keep], "v_wt": vt, "cpu_s": r["cpu_s"]}
    if "gfl" in r:
        out["gfl"] = r["gfl"]
    return out


def emt_state(r: dict) -> Stability:
    return stability(r["t"], r["v_pcc"], T_EVENT, r["v_wt"])


def emt_boundary(case: dict, t_end: float, xtol: float) -> tuple[Boundary, dict[float, dict]]:
    runs: dict[float, dict] = {}

    def ok(scr: float) -> bool:
        runs[scr] = emt_scr_run(case, scr, t_end)
        return emt_state(runs[scr]).stable

    b = threshold(ok, *SCR_RANGE, xtol)
    return b, runs


def below(emt_run: dict | None, phasor_run: dict | None) -> dict:
    """How each model is lost just below its boundary, over the run's last second: the EMT aggregate's PLL
    slip (its angle's change, Hz) and largest |v| filter output; the phasor plant's PCC voltage and its
    turbines' median current magnitude at the end (p.u.; the grid-following limit is TurbineParams.i_max_gfl
    1.1; the median is a grid-following turbine's with up to four SDViSCs among the 50)."""
    out: dict = {}
    if emt_run is not None and "gfl" in emt_run:
        g = emt_run["gfl"]
        last = g["t"] >= g["t"][-1] - 1.0
        th = g["theta"][last]
        out["emt_pll_slip_hz"] = float((th[-1] - th[0]) / (2 * np.pi * (g["t"][last][-1] - g["t"][last][0])))
        out["emt_vm_max"] = float(g["vm"][last].max())
        out["emt_v_pcc_end"] = float(emt_run["v_pcc"][-1])
    if phasor_run is not None:
        t = np.asarray(phasor_run["t"])
        last = t >= t[-1] - 1.0
        out["phasor_v_pcc_end"] = float(np.asarray(phasor_run["v_pcc"])[-1])
        out["phasor_i_wt_median_end"] = float(np.median(np.abs(np.asarray(phasor_run["i_wt"]))[-1]))
    return out


def _below_text(b: dict) -> str:
    if not b:
        return ""
    parts = []
    if "phasor_v_pcc_end" in b:
        parts.append(f"phasor: V_pcc ends {b['phasor_v_pcc_end']:.3f}, the turbines' current (median) "
                     f"{b['phasor_i_wt_median_end']:.3f} p.u. (limit 1.1)")
    if "emt_pll_slip_hz" in b:
        if abs(b["emt_pll_slip_hz"]) > SLIP_HZ:
            parts.append(f"EMT: the aggregate's PLL slips at {b['emt_pll_slip_hz']:.1f} Hz, its |v| filter up to "
                         f"{b['emt_vm_max']:.2f} p.u. (loss of synchronism; an ideal current source, no modulation "
                         "limit)")
        else:
            parts.append(f"EMT: the aggregate's PLL stays locked (slip {b['emt_pll_slip_hz']:+.2f} Hz), V_pcc ends "
                         f"{b['emt_v_pcc_end']:.3f}")
    return "Just below each boundary, last 1 s: " + "; ".join(parts) + ". "


def _fmt(x: float | None) -> str:
    return "none in the range" if x is None else f"{x:.3f}"


def _scr_verdict(emt: float | None, phasor: float | None) -> str:
    if emt is None or phasor is None:
        return "yes" if emt is None and phasor is None else "no"
    d = abs(emt - phasor)
    return "yes" if d <= SCR_YES else "partly" if d <= SCR_PARTLY else "no"


def _weak(ctx: Context) -> dict[str, Finding]:
    t_end, xtol = f7_search_settings(ctx.quick)
    xtol_emt = max(xtol, QUICK_XTOL) if ctx.quick else xtol
    found: dict[str, Finding] = {}
    traces: dict[str, dict] = {}
    cpu = {}
    for claim, (name, case) in zip(("EMTW.F7a", "EMTW.F7b", "EMTW.F7c"), CASES.items()):
        b_e, runs = emt_boundary(case, t_end, xtol_emt)
        b_p, p_runs = search_boundary(name, t_end, xtol, "stable")
        cpu[name] = sum(r["cpu_s"] for r in runs.values())
        e, p = b_e.value, b_p.value
        traces[name] = {"emt": {x: runs[x] for x in (b_e.bracket or ())}, "phasor": p_runs}
        states = "; ".join(f"SCR {x:.3f}: {emt_state(r).describe()}" for x, r in sorted(runs.items()))
        low_e = runs.get(b_e.bracket[0]) if b_e.bracket else None
        low_p = p_runs.get(b_p.bracket[0]) if b_p.bracket else None
        measured = {"emt_boundary_scr": e, "phasor_boundary_scr": p, "emt_evaluations": b_e.evaluations,
                    "emt_cpu_s": cpu[name], "below": below(low_e, low_p)}
        if name in PAPER:
            measured["printed"] = {"reading": f"EMT: SCR step at 1 s, {name}: the boundary below which the farm is "
                                              "not stable (PCC V1, report/stability.py)",
                                   "value": _fmt(e), "verdict": close_to(e, PAPER[name]) if e is not None else "no"}
        found[claim] = Finding(
            f"{name}: SCR boundary {_fmt(p)} phasor, {_fmt(e)} EMT",
            _scr_verdict(e, p),
            f"yes = within {SCR_YES} SCR of the phasor plant's, partly = within {SCR_PARTLY}; bisection in "
            f"[{SCR_RANGE[0]:g}, {SCR_RANGE[1]:g}] to {xtol} (EMT: {xtol_emt}), {t_end:g} s runs, both models. "
            f"EMT runs: {states}. " + _below_text(measured["below"]) +
            "The EMT farm: one aggregated grid-following converter with the phasor turbine's controls (module "
            "docstring)"
            + (f". Paper: {PAPER[name]}" if name in PAPER else ""), measured)
    f9_t, _ = f9_settings(ctx.quick)
    for claim, n in (("EMTW.F9a", 3), ("EMTW.F9b", 4)):
        r = emt_scr_run({"n_visc": n, "visc_params": visc_params(VIRTUAL_FRICTION_DEFAULT)}, F9_SCR, f9_t)
        s_e, s_p = emt_state(r), of_run(f9_run(n, f9_t, VIRTUAL_FRICTION_DEFAULT), T_EVENT)
        traces[f"F9 {n}"] = {"emt": {F9_SCR: r}, "phasor": {F9_SCR: f9_run(n, f9_t, VIRTUAL_FRICTION_DEFAULT)}}
        cpu[f"F9 {n}"] = r["cpu_s"]
        measured = {"emt": vars(s_e), "phasor": vars(s_p), "emt_cpu_s": r["cpu_s"]}
        if n == 3:
            t_away = s_e.t_away
            measured["printed"] = {"reading": "EMT: when the PCC's V1 leaves the normal band for good with 3 SDViSCs "
                                              "(the aggregated farm has no WT1_CS1)",
                                   "value": "stays in the band" if t_away is None else f"{t_away:.2f} s",
                                   "verdict": close_to(t_away, 3.0) if t_away is not None else "no"}
        found[claim] = Finding(f"{n} SDViSCs at SCR {F9_SCR}: {s_p.state} phasor, {s_e.state} EMT",
                               "yes" if s_e.stable == s_p.stable else "no",
                               f"yes = the same verdict (stable or not, report/stability.py) on both models; phasor: "
                               f"{s_p.describe()}; EMT: {s_e.describe()} (terminals: the SDViSCs' only). Paper (F9): "
                               f"{'3 SDViSCs: unstable, ≈ 3 s' if n == 3 else '4 SDViSCs: stable'}", measured)
    ctx.numbers["emt_weak_cpu_s"] = cpu
    _figure(ctx, traces)
    return found


def _gfl_current(model: str, r: dict) -> tuple[np.ndarray, np.ndarray] | None:
    """(t, the grid-following turbines' current magnitude): the phasor plant's median over its turbines, the
    EMT aggregate's reference |i*| (its current follows within 0.2 ms)."""
    if model == "phasor" and "i_wt" in r:
        return np.asarray(r["t"]), np.median(np.abs(np.asarray(r["i_wt"])), axis=1)
    if model == "emt" and "gfl" in r:
        return r["gfl"]["t"], np.abs(r["gfl"]["i_ref_dq"])
    return None


def _figure(ctx: Context, traces: dict) -> None:
    fig, axes = figures.new(len(traces), cols=2, height_per_row=2.0, width=11.0)
    for (ax, ax_i), (name, tr) in zip(axes, traces.items()):
        for model, style in (("phasor", "-"), ("emt", "--")):
            for j, (scr, r) in enumerate(sorted(tr[model].items(), reverse=True)):
                ax.plot(r["t"], r["v_pcc"], color=f"C{j}", ls=style, lw=0.9,
                        label=f"{name}, SCR {scr:.3f}, {model.upper() if model == 'emt' else model}")
                cur = _gfl_current(model, r)
                if cur is not None:
                    ax_i.plot(*cur, color=f"C{j}", ls=style, lw=0.9)
        for v in V_NORMAL:
            ax.axhline(v, color="0.5", ls=":", lw=0.8)
        ax.set_ylim(0.0, 1.6)
        ax.set_ylabel("V1 PCC [p.u.]")
        ax.legend(fontsize=6, loc="lower left", ncol=2)
        ax_i.axhline(1.1, color="0.5", ls=":", lw=0.8)
        ax_i.set_ylim(0.0, 1.3)
        ax_i.set_ylabel("GFL turbines' |i| [p.u.]")
    axes[-1, 0].set_xlabel("t [s] (SCR 7.14 → the value shown at 1 s); solid phasor, dashed EMT (DPsim)")
    axes[-1, 1].set_xlabel("t [s]; phasor: the turbines' median, EMT: the aggregate's |i*|; limit 1.1")
    figures.save(ctx, fig, "emt_f7_f9", "F7's boundaries and F9's cases on the EMT backend (dashed) over the phasor "
                 "plant (solid): the runs either side of each model's boundary; right, the grid-following turbines' "
                 "current: below the boundary the phasor plant's sit at their limit in a sag, the EMT aggregate's "
                 "PLL slips and its reference P*/V_m falls as its |v| filter rises (no modulation limit).", prefix="Cross-check: ")


EMTW_CLAIMS = (
    PaperClaim("EMTW.F7a", "F7's SCR boundary without SC or SDViSC on the EMT backend as on the phasor plant",
               "SCR boundary 2.04", kind=CONSISTENCY),
    PaperClaim("EMTW.F7b", "F7's SCR boundary with the SC on the EMT backend as on the phasor plant",
               "SCR boundary 1.58", kind=CONSISTENCY),
    PaperClaim("EMTW.F7c", "F7's SCR boundary with SDViSCs (the four of cluster 3) on the EMT backend as on the "
               "phasor plant", "boundary < 1.58", kind=CONSISTENCY),
    PaperClaim("EMTW.F9a", "F9's case with 3 SDViSCs (SCR 7.14 → 1.51) on the EMT backend as on the phasor plant",
               "3 SDViSCs: unstable", kind=CONSISTENCY),
    PaperClaim("EMTW.F9b", "F9's case with 4 SDViSCs on the EMT backend as on the phasor plant", "4 SDViSCs: stable",
               kind=CONSISTENCY),
)

EMTW = Experiment("EMTW", "EMT cross-check of F7 and F9: weak-grid SCR steps (DPsim)", "Figs. Compare_Weak, "
                  "study2_Weak_noVSC", "offline", EMTW_CLAIMS, _weak, "",
                  "Offline; needs the optional extra `emt`. The farm one aggregated current source with the WPP's Q; "
                  "F7's SDViSC case as the four SDViSCs of cluster 3.")
