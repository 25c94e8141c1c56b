"""B1net (beyond the paper, issue 9): B1's delay limit confirmed through the network.

B1 sweeps an added delay offline (the CTRL held at the turbine). Here the same question is asked
of the real loop: F1's fault case (scenarios/paper/f1_tustin_vs_hd.yaml) with the four SDViSCs of
cluster 3, whose MEAS and CTRL all cross the link c2–c3, and that link given a delay of d/2 in each
direction (a link impairment element, docs/scenarios.md "Impairments": the loop sees d more per
round trip). The offline sweep of the same case finds where v_ref goes unstable; the network runs
no added delay, the last stable and the first unstable delay. The runs use a fixed time scale (the k the
calibration chose in this report for the same network without the impairment, else 16): ``auto``
would reject every k, since the added delay is simulated time and does not shrink with k."""

from __future__ import annotations

import numpy as np

from plant.cosim import FaultCase, run_hd, samples_for_delay
from report import figures, network_runs
from report.beyond import ACCEPT_PCT, UNSTABLE_CRITERION, instability
from report.exp_delay import DELAYS_MS, QUICK_DELAYS_MS, limits, sweep
from report.plantcases import visc_indices
from report.registry import CONSISTENCY, MEASURED, Context, Experiment, Finding, PaperClaim

NAME = "f1_tustin_vs_hd"
CLUSTER3 = ["wt3_1", "wt3_2", "wt3_3", "wt3_4"]
IMPAIRED_LINK = ("c2", "c3")  # on the shortest path of every cluster-3 turbine (compact farm ring)
DEFAULT_TIME_SCALE = 16.0

CLAIMS = (PaperClaim("B1net.a", "Added round-trip delay at which the SDViSC (remote_apply = v_ref) goes unstable — "
                     "the offline sweep's boundary, run through the network with the delay on a link", "not stated",
                     beyond=True, kind=CONSISTENCY),)


def variant(delay_ms: float, time_scale: float) -> dict:
    """The changes to the F1 file: the four SDViSCs of cluster 3, recorded; the link c2–c3 delayed by
    ``delay_ms`` / 2 each way (none at 0); a fixed time scale."""
    def timeline(tl: list[dict]) -> list[dict]:
        others = [e for e in tl if e["do"] != "visc_on"]
        template = next(e for e in tl if e["do"] == "visc_on")
        return [dict(template, wt=wt) for wt in CLUSTER3] + others

    changes = {"timeline": timeline, "time_scale": time_scale,
               "plant": lambda p: {**p, "record": list(CLUSTER3), "record_every": 5}}
    if delay_ms > 0:
        changes["links"] = [{"a": IMPAIRED_LINK[0], "b": IMPAIRED_LINK[1], "delay_ms": delay_ms / 2}]
    return changes


def _b1net(ctx: Context) -> dict[str, Finding]:
    sc = network_runs.load(NAME)
    case = FaultCase(visc_turbines=tuple(int(i) for i in visc_indices(len(CLUSTER3))), t_end_s=float(sc["duration_s"]))
    hd = run_hd(case)
    points = sweep(case, hd, QUICK_DELAYS_MS if ctx.quick else DELAYS_MS, "v_ref")
    boundary = limits(points)["unstable"]
    chosen = sorted({0.0} | {d for d in (boundary.last_good, boundary.first_bad) if d is not None})  # 0: the bare loop
    k = network_runs.known_time_scale(network_runs.apply_changes(sc, variant(0.0, 1.0))) or DEFAULT_TIME_SCALE
    seen = {}
    for d in chosen:
        summary, ts = network_runs.run_variant(ctx, NAME, f"b1net_delay_{d:g}ms", variant(d, k))
        v_hd = np.interp(ts["t"], hd["t"], hd["v_pcc"][:, 0])
        trips = summary.get("converter_trips") or {}
        why = instability(ts["t"], ts["v_pcc"], v_hd, [len(trips)])
        samples = {wt: summary["turbines"][wt].get("round_trip_samples", {}).get("counts", {}) for wt in CLUSTER3}
        seen[d] = {"ts": ts, "unstable": why, "fallbacks": summary.get("fallbacks") or {}, "trips": trips,
                   "round_trip_samples": _merged(samples)}
    offline = {p["delay_ms"]: p["unstable"] for p in points}
    fig, axes = figures.new(1, height_per_row=3.2)
    ax = axes[0, 0]
    ax.axvspan(case.t_fault_s, case.t_clear_s, **figures.FAULT_SHADE)
    ax.plot(hd["t"], hd["v_pcc"][:, 0], "k", lw=1.6, label="HD ViSC (offline)")
    for i, (d, s) in enumerate(seen.items()):
        ax.plot(s["ts"]["t"], s["ts"]["v_pcc"], f"C{i}", lw=1.0, ls=("-", "--")[i % 2],
                label=f"network, +{d:g} ms per round trip (c2–c3 {d / 2:g} ms each way, k = {k:g}): "
                      + ("unstable" if s["unstable"] else "stable"))
    ax.set_ylabel("|V_pcc| [p.u.]")
    ax.set_xlabel(f"t [s] (SLG fault {case.t_fault_s}–{case.t_clear_s} s; four SDViSCs of cluster 3, v_ref)")
    ax.legend(fontsize=7, loc="lower right")
    figures.save(ctx, fig, "b1net_delay_through_network", "the delay at which the SDViSC goes unstable, offline "
                 "(CTRL held) and through the network (a delayed link).", prefix="Beyond the paper (network): ")
    agree = all((seen[d]["unstable"] is None) == (offline[d] is None) for d in seen)
    text = ("; ".join(f"+{d:g} ms: network {'unstable' if s['unstable'] else 'stable'}, offline "
                      f"{'unstable' if offline[d] else 'stable'}" for d, s in seen.items())
            or "offline stable over the whole sweep: nothing to confirm")
    ctx.notes.append(f"Offline sweep of this case (v_ref, CTRL held): {boundary.describe('stable', 'unstable', 'ms')}; "
                     f"the network runs at time scale {k:g} (fixed, see the module) with c2–c3 delayed by d / 2 each way.")
    return {"B1net.a": Finding(
        text + (" — the network agrees with offline" if agree and seen else " — the network differs from offline")
        + f" (k = {k:g}; the network's own round trip is its wall time / k in simulated time: the margin can change with k)",
        MEASURED, f"{UNSTABLE_CRITERION}; within = {ACCEPT_PCT:g} % of the HD ViSC (B1). Network runs: "
        + "; ".join(f"+{d:g} ms: {s['unstable'] or 'stable'}, fall-backs {s['fallbacks'] or 'none'}, MEAS→CTRL round "
                    f"trip in samples (the four; offline: exactly {1 + samples_for_delay(d * 1e-3, case.step_s)}) "
                    + _share(s["round_trip_samples"]) for d, s in seen.items())
        + ". Where network and offline differ at the same round trip in samples, the difference is not the "
        "sample count (why it is, is not established: e.g. when in the sample the CTRL arrives)",
        {"offline_last_stable_ms": boundary.last_good, "offline_first_unstable_ms": boundary.first_bad,
         "network_unstable": {d: s["unstable"] for d, s in seen.items()}, "time_scale": k, "agrees": agree,
         "round_trip_samples": {d: s["round_trip_samples"] for d, s in seen.items()}})}


def _merged(counts: dict[str, dict[str, int]]) -> dict[str, int]:
    """The turbines' round-trip histograms (samples -> answers) added up, in order of samples; the
    runner's last bin is ">N" (more than N samples), after N."""
    out: dict[str, int] = {}
    for hist in counts.values():
        for n, c in hist.items():
            out[n] = out.get(n, 0) + int(c)
    return dict(sorted(out.items(), key=lambda kv: int(kv[0].lstrip(">")) + kv[0].startswith(">")))


def _share(hist: dict[str, int]) -> str:
    total = sum(hist.values()) or 1
    return ", ".join(f"{n}: {c / total:.1%}" for n, c in hist.items() if c / total >= 0.001) or "none"


B1NET = Experiment("B1net", "B1 through the network: the delay limit on a real link", "— (beyond the paper)", "cyber",
                   CLAIMS, _b1net, network_runs.command(NAME),
                   "Beyond the paper (issue 9): F1's fault with the four SDViSCs of cluster 3, the link c2–c3 delayed "
                   "by d / 2 each way (impairment element) at the offline sweep's last stable and first unstable d; "
                   "fixed time scale (the changed files in <out>/scenarios/).")
