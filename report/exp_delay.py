"""B1 (beyond the paper, issue 9): how much network delay an SDViSC takes -- offline.

F1's case (SLG fault at the PCC 1.0–1.3 s, four SDViSCs, one per cluster, the full farm; Tustin at
Ts = 0.67 ms) co-simulated in one process (plant/cosim.py) with an added delay d on the SDC's loop,
realised as the CTRL held at the turbine: a CTRL is applied at the first sample at or after its
arrival, i.e. ceil(d / Ts) samples later than in F1's loop (0 = the paper's loop: the answer to a
sample drives the next plant step). The delay is added in one direction; a delay d on a link the
MEAS and the CTRL both cross counts twice (the loop sees the sum). Both arrangements of the remote
mode: ``v_ref`` (the SDC closes the inner current loop, as the paper's SDC outputs the modulation
signals) and ``i_ref`` (the SDC sends the limited current reference, the converter keeps its own
current loop); see docs/sdc.md, ``remote_apply``. Every run is compared with the HD reference
(plant/hd_reference.py: the continuous law with the SDC's own parameters at 50 µs) at the SDC's
sample instants."""

from __future__ import annotations

import numpy as np

from plant import hd_reference
from plant.cosim import FaultCase, compare, run_sdc, samples_for_delay
from report import figures
from report.beyond import ACCEPT_PCT, UNSTABLE_CRITERION, crossing, instability, worst_pct
from report.registry import MEASURED, Context, Experiment, Finding, PaperClaim
from report.verdicts import holds

DELAYS_MS = (0.0, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0)  # the sweep
EXTRA_MS = (50.0, 100.0)  # full run only: past the sweep, to find where a tolerant arrangement fails
QUICK_DELAYS_MS = (0.0, 1.0, 5.0, 20.0)
OPTIONS = ("v_ref", "i_ref")
LOW_DELAY_MS = 5.0  # B1.a: "low delay indispensable" holds when the paper's arrangement leaves ACCEPT_PCT by this
REALISATION = "CTRL held at the turbine, offline"
QUANTITY_LABELS = {"v_pcc": "|V_pcc|", "q": "Q", "delta": "δ", "e_mag": "E"}

CLAIMS = (
    PaperClaim("B1.a", "A dependable communication network with low delays is indispensable for SDViSC operation "
               "(Section III); the SDC acts on the measurements of each sampling time (Section II-D)",
               "low delays indispensable (no number)"),
    PaperClaim("B1.b", "Added delay (CTRL held at the turbine, offline) at which the SDViSC with remote_apply = v_ref "
               "(the SDC closes the inner current loop) stops being within 5 % of the HD ViSC, and goes unstable",
               "not stated", beyond=True),
    PaperClaim("B1.c", "The same for remote_apply = i_ref (the converter keeps its own current loop)", "not stated",
               beyond=True),
)


def _case(quick: bool) -> FaultCase:
    return FaultCase(t_end_s=2.0 if quick else 3.0)


def sweep(case: FaultCase, hd: dict, delays_ms, option: str) -> list[dict]:
    """One run per added delay (ascending, the first 0): errors vs the HD reference ``hd`` (taken at the
    SDC's sample instants, ``hd_reference.reference_on_samples``) and vs this arrangement's own run without
    added delay, the instability (None if stable), the |V_pcc| trace at the sample instants."""
    points, base = [], None
    for d in delays_ms:
        n = samples_for_delay(d * 1e-3, case.step_s)
        r = hd_reference.on_samples(run_sdc(case, method="tustin", delay_samples=n, remote_apply=option), case)
        base = r if base is None else base
        cmp, own = compare(r, hd), compare(r, base)
        why = instability(r["t"], r["v_pcc"][:, 0], hd["v_pcc"][:, 0], r["trips"], r["trip_t"])
        points.append({"delay_ms": d, "samples": n, "pct": {q: c["rms_over_range_pct"] for q, c in cmp.items()},
                       "worst_pct": worst_pct(cmp), "own_worst_pct": worst_pct(own), "unstable": why,
                       "v_pcc": r["v_pcc"][:, 0]})
    return points


def limits(points: list[dict]) -> dict:
    """Where along the sweep the arrangement leaves ACCEPT_PCT of the HD ViSC, of its own no-delay run,
    and where it goes unstable (an unstable run is never "within")."""
    d = [p["delay_ms"] for p in points]
    unstable = [p["unstable"] is not None for p in points]
    return {"hd": crossing(d, [p["worst_pct"] > ACCEPT_PCT or u for p, u in zip(points, unstable)]),
            "own": crossing(d, [p["own_worst_pct"] > ACCEPT_PCT or u for p, u in zip(points, unstable)]),
            "unstable": crossing(d, unstable)}


def verdict_low_delay(hd_limit, low_ms: float = LOW_DELAY_MS) -> tuple[str, str]:
    """B1.a from the paper's arrangement's crossing of ACCEPT_PCT: yes if it leaves within ``low_ms`` of
    added delay, partly if later within the sweep, no if never (or if it is not within even without delay)."""
    if hd_limit.last_good is None:
        return "no", "not within 5 % of the HD ViSC even without added delay: the sweep cannot show what delay costs"
    if hd_limit.first_bad is None:
        return "no", f"within {ACCEPT_PCT:g} % of the HD ViSC over the whole sweep: delay up to {hd_limit.swept[-1]:g} ms costs little"
    verdict = holds(hd_limit.first_bad <= low_ms, partly=True)
    return verdict, (f"criterion: the paper's arrangement (v_ref) leaves {ACCEPT_PCT:g} % of the HD ViSC at an added "
                     f"delay ≤ {low_ms:g} ms: yes; later within the sweep: partly; never: no")


def _describe(lim: dict, points: list[dict], option: str) -> str:
    first = points[0]
    worst_q = max(first["pct"], key=first["pct"].get)
    text = (f"{lim['hd'].describe(f'within {ACCEPT_PCT:g} % of the HD ViSC', 'not', 'ms')}; "
            f"{lim['unstable'].describe('stable', 'unstable', 'ms')}")
    text += f"; without added delay worst {first['worst_pct']:.2f} % ({QUANTITY_LABELS[worst_q]})"
    if lim["hd"].last_good is None or option == "i_ref":
        text += "; " + lim["own"].describe(f"within {ACCEPT_PCT:g} % of its own no-delay run", "not", "ms")
    return text


def _samples(n: int) -> str:
    return f"{n} sample" + ("" if n == 1 else "s")


def _evidence(points: list[dict]) -> str:
    def one(p):
        state = f" — {p['unstable']}" if p["unstable"] else ""
        return f"{p['delay_ms']:g} ms ({_samples(p['samples'])}): {p['worst_pct']:.2f} %{state}"

    return "worst RMS / HD range per added delay: " + "; ".join(one(p) for p in points)


def _b1(ctx: Context) -> dict[str, Finding]:
    case = _case(ctx.quick)
    delays = QUICK_DELAYS_MS if ctx.quick else DELAYS_MS + EXTRA_MS
    hd = hd_reference.reference_on_samples(case)
    runs = {opt: sweep(case, hd, delays, opt) for opt in OPTIONS}
    lims = {opt: limits(pts) for opt, pts in runs.items()}
    ctx.numbers["delay_sweep"] = {opt: [{k: v for k, v in p.items() if k != "v_pcc"} for p in pts]
                                  for opt, pts in runs.items()}
    ctx.numbers["limits_ms"] = {opt: {k: {"last_good": c.last_good, "first_bad": c.first_bad} for k, c in lim.items()}
                                for opt, lim in lims.items()}
    ctx.notes += [
        f"Delay realised as the {REALISATION}: held ceil(d / Ts) samples of Ts = {case.step_s * 1e3:.2f} ms "
        "(" + ", ".join(f"{p['delay_ms']:g} ms → {p['samples']}" for p in runs['v_ref']) + "), on top of F1's loop "
        "(the answer to a sample drives the next plant step). Added in one direction: a link delay crossed by MEAS "
        "and CTRL counts twice.",
        f"Within = worst RMS deviation of |V_pcc|, Q, δ, E / range of the HD trace ≤ {ACCEPT_PCT:g} % over "
        f"0–{case.t_end_s:g} s, and stable; the HD reference: {hd_reference.LABEL} (plant/hd_reference.py), taken "
        f"at the SDC's sample instants. {UNSTABLE_CRITERION}",
        "i_ref without added delay is not the HD reference either: the converter's loop of the remote mode is "
        "proportional only (v_conv = v + (r_f + j l_f) i_ref + k_pc (i_ref − i)), not the law's PI (no integral "
        "ξ), and it tracks a reference sampled every Ts (δ "
        f"{runs['i_ref'][0]['pct']['delta']:.1f} % of the HD range); its own no-delay run is the second reference.",
    ]
    _figure_errors(ctx, runs, lims, case)
    _figure_traces(ctx, runs, lims, hd, case)
    v_lim = lims["v_ref"]["hd"]
    verdict, criterion = verdict_low_delay(v_lim)
    a = Finding(f"v_ref: {v_lim.describe(f'within {ACCEPT_PCT:g} %', 'not', 'ms')}; i_ref: "
                f"{lims['i_ref']['own'].describe(f'within {ACCEPT_PCT:g} % of its no-delay run', 'not', 'ms')}",
                verdict, f"{criterion}. {_evidence(runs['v_ref'])}",
                {"v_ref_first_bad_ms": v_lim.first_bad, "low_delay_ms": LOW_DELAY_MS})
    found = {"B1.a": a}
    for cid, opt in (("B1.b", "v_ref"), ("B1.c", "i_ref")):
        found[cid] = Finding(_describe(lims[opt], runs[opt], opt), MEASURED,
                             f"{REALISATION}. {_evidence(runs[opt])}. {UNSTABLE_CRITERION}",
                             ctx.numbers["limits_ms"][opt])
    return found


def _figure_errors(ctx: Context, runs: dict, lims: dict, case: FaultCase) -> None:
    fig, axes = figures.new(1, 2, height_per_row=4.0, width=10.0, sharex=False)
    for ax, opt in zip(axes[0], OPTIONS):
        pts, lim = runs[opt], lims[opt]
        d = np.array([p["delay_ms"] for p in pts])
        for q, style in zip(QUANTITY_LABELS, ("C0", "C1", "C2", "C4")):
            ax.plot(d, [max(p["pct"][q], 1e-3) for p in pts], style, lw=0.9, marker=".", label=QUANTITY_LABELS[q])
        ax.plot(d, [min(p["worst_pct"], 1e3) for p in pts], "k", lw=2.0, label="worst of the four vs HD ViSC")
        ax.plot(d[1:], [min(p["own_worst_pct"], 1e3) for p in pts[1:]], color="0.45", ls="--", lw=1.2,
                label="worst vs its own run without added delay")
        bad = [p for p in pts if p["unstable"]]
        if bad:
            ax.plot([p["delay_ms"] for p in bad], [min(p["worst_pct"], 1e3) for p in bad], "rx", ms=9, mew=2,
                    label="unstable (trip, divergence or oscillation)")
            ax.axvspan(lim["unstable"].first_bad, d[-1] * 1.5, color="C3", alpha=0.08, zorder=0)
        ax.axhline(ACCEPT_PCT, color="C3", ls="--", lw=1.0, label=f"{ACCEPT_PCT:g} % (within the HD ViSC)")
        ax.axhline(1.0, color="C3", ls=":", lw=0.8, label="1 % (F1's criterion)")
        for crossed, color, what in ((lim["hd"], "k", "HD ViSC"), (lim["own"], "0.45", "no-delay run")):
            if crossed.first_bad is not None and crossed.last_good is not None:
                ax.axvline(crossed.first_bad, color=color, ls="-.", lw=0.9)
                ax.annotate(f"leaves {ACCEPT_PCT:g} % of the {what} at {crossed.first_bad:g} ms",
                            (crossed.first_bad, 1.2e-2), fontsize=7, rotation=90, va="bottom", ha="right", color=color)
        if lim["hd"].last_good is None:
            ax.annotate(f"never within {ACCEPT_PCT:g} % of the HD ViSC", (0.02, 0.96), xycoords="axes fraction",
                        fontsize=7.5, va="top")
        ax.set_xscale("symlog", linthresh=0.5, linscale=0.4)
        ax.set_xticks(list(d))
        ax.set_xticklabels([f"{x:g}" for x in d], fontsize=7.5)
        ax.set_xlim(-0.05, d[-1] * 1.2)
        ax.set_yscale("log")
        ax.set_ylim(1e-2, 3e2)
        ax.set_title(f"remote_apply = {opt}", fontsize=10)
        ax.set_xlabel("added delay d [ms] (log scale above 0.5 ms)")
    axes[0, 0].set_ylabel("RMS deviation / HD range [%] (log scale)")
    handles = {}
    for ax in axes[0]:
        handles.update({label: h for h, label in zip(*ax.get_legend_handles_labels()) if label not in handles})
    fig.legend(list(handles.values()), list(handles), fontsize=7.5, loc="upper center", ncol=4)
    figures.save(ctx, fig, "b1_error_vs_delay",
                 f"RMS deviation from the HD ViSC (% of the HD trace's range, 0–{case.t_end_s:g} s) vs the delay added "
                 f"to the SDC's loop, F1's SLG fault, Tustin at {case.step_s * 1e3:.2f} ms, {REALISATION}. "
                 "Red shade: unstable from there on.", prefix="Beyond the paper (offline): ", top=0.86)


def _figure_traces(ctx: Context, runs: dict, lims: dict, hd: dict, case: FaultCase) -> None:
    fig, axes = figures.new(2, height_per_row=2.6)
    for ax, opt in zip(axes[:, 0], OPTIONS):
        pts, lim = runs[opt], lims[opt]
        wanted = {0.0, lim["hd"].last_good, lim["hd"].first_bad, lim["own"].first_bad, lim["unstable"].last_good,
                  lim["unstable"].first_bad, pts[-1]["delay_ms"]}
        shown = [p for p in pts if p["delay_ms"] in wanted]
        ax.axvspan(case.t_fault_s, case.t_clear_s, **figures.FAULT_SHADE)
        ax.plot(hd["t"], hd["v_pcc"][:, 0], "k", lw=1.8, label="HD reference (50 µs, at the SDC's samples)")
        for i, p in enumerate(shown):
            state = f" ({p['unstable'].split(':')[0]})" if p["unstable"] else ""
            ax.plot(hd["t"], p["v_pcc"], color=f"C{i}", lw=1.0, ls=("--", "-", ":", "-.")[i % 4],
                    label=f"d = {p['delay_ms']:g} ms ({_samples(p['samples'])}){state}")
        ax.set_ylabel("|V_pcc| [p.u.]")
        ax.set_title(f"remote_apply = {opt}", fontsize=10)
        ax.legend(fontsize=7, loc="lower right")
    axes[-1, 0].set_xlabel(f"t [s] (SLG fault at the PCC {case.t_fault_s}–{case.t_clear_s} s, shaded; four SDViSCs)")
    figures.save(ctx, fig, "b1_vpcc_traces",
                 f"|V_pcc| with the SDViSC's CTRL delayed by d ({REALISATION}), at the delays where the sweep changes "
                 "(none, last within 5 %, first outside, last stable, first unstable, the largest). A tripped converter runs "
                 "grid-following from its trip on.", prefix="Beyond the paper (offline): ")


B1 = Experiment("B1", "How much network delay an SDViSC takes", "— (beyond the paper)", "offline", CLAIMS,
                _b1, "", "Beyond the paper (issue 9), offline: F1's case in plant/cosim.py with the CTRL held at the "
                "turbine for the added delay (whole samples, ceil), remote_apply v_ref and i_ref. Not a network run: "
                "no jitter, loss or queueing; the delay is constant.")
