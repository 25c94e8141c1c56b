"""F4h and F4hnet: the paper's "Programmable H = 3 s and H = 5 s for SDViSC" (Fig. Compare_inertia1
(c), issue 28 item 8) as a run-time change: H 3 s → 5 s by an OWFCC ``set_params`` between two
+50 MW load steps (scenarios/paper/f4_programmable_h.yaml). F4h runs it offline with the SDC's own
controller bank (report/programmable_h.py) beside a control run that keeps H 3 s, F4hnet through the
network at the auto time scale: the SDC's record of what it applied, and the two steps' dips against
the offline run."""

from __future__ import annotations

import json

from report import figures, network_runs
from report import programmable_h as ph
from report.registry import CONSISTENCY, Context, Experiment, Finding, PaperClaim
from report.verdicts import close_to, holds
from sdc_unit.params import ViscParams

CLEAR = 0.05  # a "clear" reduction of the dip: at least this fraction of it (as F4.b)
AGREE_YES, AGREE_PARTLY = 0.10, 0.35  # |network − offline| / |offline| (the report's usual rule)

F4H_CLAIMS = (
    PaperClaim("F4h.a", "Programmable H: raising the SDViSCs' H from 3 s to 5 s at run time (an OWFCC request) "
               "reduces the frequency dip of the next +50 MW step", "smaller nadir"),
    PaperClaim("F4h.b", "… and lowers the oscillation frequency", "lower oscillation frequency"),
)
F4HNET_CLAIMS = (
    PaperClaim("F4hnet.a", "H is programmable at run time through the network: the OWFCC's set_params {h: 5} "
               "reaches the SDC, which steps the four SDViSCs with H 5 s from then on", "H 3 s → 5 s at run time"),
    PaperClaim("F4hnet.b", "… and the frequency dips before and after the change are those of the same case "
               "offline", "dips as offline", kind=CONSISTENCY),
)


def _runs(c: dict) -> dict[str, dict]:
    return {"sdc": ph.run_sdc(c), "sdc_h_kept": ph.run_sdc(c, switch=False), "hd": ph.run_hd(c),
            "hd_h_kept": ph.run_hd(c, switch=False)}


def _why(c: dict, before: dict) -> str:
    """The physical reason the effect is small, with this case's numbers."""
    e = ph.inertia_mws(c)
    p = ViscParams()
    n = len(c["turbines"])
    damping_mw = n * 10.0 * p.d * abs(before["dip_hz"]) / 50.0
    return (f"{n} × 10 MVA × H = {e['visc_before']:g} → {e['visc_after']:g} MWs against the grid source's "
            f"{e['grid']:g} MWs (H {c['grid'].get('h_grid', 0):g} s on {c['grid'].get('s_grid_mva', 0):g} MVA, "
            f"assumed): +{(e['visc_after'] - e['visc_before']) / e['grid']:.1%} of the stored energy; and with "
            f"D = {p.d:g} and ω_s nominal the SDViSC is a fast droop on the frequency (D·Δω: "
            f"{damping_mw:.0f} MW at the dip) that follows the grid within 2H/D = "
            f"{2 * c['h_before'] / p.d * 1000:.0f} → {2 * c['h_after'] / p.d * 1000:.0f} ms, far faster than the "
            "grid's own swing: H only shifts that short lag")


def _f4h(ctx: Context) -> dict[str, Finding]:
    c = ph.case()
    runs = _runs(c)
    ev = {name: ph.events_of(r, c) for name, r in runs.items()}
    first, after, kept = ev["sdc"][0], ev["sdc"][1], ev["sdc_h_kept"][1]
    gain = after["dip_hz"] - kept["dip_hz"]  # > 0: a smaller dip with H 5 s than with H 3 s kept
    ctx.numbers["f4h"] = {"events": ev, "h_in_effect_at_end": runs["sdc"]["h_end"], "inertia_mws": ph.inertia_mws(c)}
    hd_gain = ev["hd"][1]["dip_hz"] - ev["hd_h_kept"][1]["dip_hz"]
    step2 = f"+{c['loads'][1][1]:g} MW at {c['loads'][1][0]:g} s"
    a = Finding(
        f"dip before (H {c['h_before']:g} s, +{c['loads'][0][1]:g} MW at {c['loads'][0][0]:g} s) "
        f"{first['dip_hz']:+.4f} Hz (nadir {first['nadir_hz']:+.4f}); after H → {c['h_after']:g} s ({step2}) "
        f"{after['dip_hz']:+.4f} Hz, with H {c['h_before']:g} s kept {kept['dip_hz']:+.4f} Hz (H's effect "
        f"{gain:+.4f} Hz)",
        holds(gain >= CLEAR * abs(kept["dip_hz"]), partly=gain > 0),
        f"H's effect = the second step's dip with H changed minus the same with H {c['h_before']:g} s kept (the two "
        "steps start from different operating points: the first step's governor response still settling, 100 MW "
        f"in total), clear = ≥ {CLEAR:.0%} of the dip; dip = lowest f_pcc − its mean over the "
        f"{ph.PRE_EVENT_S:g} s before (to {ph.END_MARGIN_S * 1000:g} ms before). Offline, the SDC's controller bank (Tustin, one sample of round trip) with "
        f"its set_params at {c['t_set']:g} s; the continuous law (hd_visc, Plant.set_visc_params) gives "
        f"{hd_gain:+.4f} Hz. Why so small: {_why(c, first)}",
        {"dip_before_hz": first["dip_hz"], "dip_after_hz": after["dip_hz"], "dip_h_kept_hz": kept["dip_hz"],
         "effect_hz": gain, "effect_hd_hz": hd_gain})
    lower = after["osc_hz"] < kept["osc_hz"]
    later = after["t_nadir_s"] - kept["t_nadir_s"]
    b = Finding(
        f"dominant oscillation {first['osc_hz']:.3f} Hz before, {after['osc_hz']:.3f} Hz after H → "
        f"{c['h_after']:g} s ({kept['osc_hz']:.3f} Hz with H kept); nadir {first['t_nadir_s']:.2f} s after the step "
        f"before, {after['t_nadir_s']:.2f} s after ({kept['t_nadir_s']:.2f} s with H kept)",
        holds(lower, partly=later > 0),
        "largest peak of the zero-padded periodogram of the detrended f_pcc over each step's window "
        f"({after['window_s']:.2f} s each: peaks closer than ≈ {1 / after['window_s']:.2f} Hz "
        "are not resolved); partly = only the nadir came later (a slower swing). What oscillates is the grid "
        "source against its governor (≈ 0.2 Hz); the SDViSCs' own swing is damped by D "
        f"(no ringing in their power). {_why(c, first)}",
        {"osc_before_hz": first["osc_hz"], "osc_after_hz": after["osc_hz"], "osc_h_kept_hz": kept["osc_hz"],
         "nadir_later_s": later})
    _figure(ctx, c, runs)
    return {"F4h.a": a, "F4h.b": b}


def _figure(ctx: Context, c: dict, runs: dict, network: dict | None = None, k=None) -> None:
    fig, axes = figures.new(2, height_per_row=2.4, sharex=False)
    ax = axes[0, 0]
    ax.plot(runs["sdc_h_kept"]["t"], runs["sdc_h_kept"]["f"], "0.6", lw=1.0, label=f"H {c['h_before']:g} s kept")
    ax.plot(runs["sdc"]["t"], runs["sdc"]["f"], "k", lw=1.3,
            label=f"H {c['h_before']:g} → {c['h_after']:g} s at {c['t_set']:g} s (offline, SDC bank)")
    if network is not None:
        ax.plot(network["t"], network["f"], "C1--", lw=1.0, label=f"through the network, k = {k}")
    ax.axvline(c["t_set"], color="C2", ls="--", lw=0.9)
    for t, _ in c["loads"]:
        ax.axvline(t, color="C3", ls=":", lw=0.9)
    ax.set_ylabel("PCC frequency [Hz]")
    ax.set_xlabel(f"t [s] (+{c['loads'][0][1]:g} MW at {', '.join(f'{t:g}' for t, _ in c['loads'])} s; "
                  f"set_params h {c['h_after']:g} at {c['t_set']:g} s)")
    ax.legend(fontsize=7)
    ax = axes[1, 0]
    steps = [(runs["sdc"], 0, f"step 1, H {c['h_before']:g} s", "k", ":"),
             (runs["sdc"], 1, f"step 2, H {c['h_after']:g} s", "k", "-"),
             (runs["sdc_h_kept"], 1, f"step 2, H {c['h_before']:g} s kept", "0.6", "-")]
    if network is not None:
        steps += [(network, j, f"step {j + 1}, network", "C1", "--") for j in (0, 1)]
    for r, j, label, colour, ls in steps:
        t0, t1 = ph.event_windows(c, float(r["t"][-1]))[j]
        base = r["f"][(r["t"] >= t0 - ph.PRE_EVENT_S) & (r["t"] < t0)].mean()
        w = (r["t"] >= t0 - ph.PRE_EVENT_S) & (r["t"] < t1)
        ax.plot(r["t"][w] - t0, r["f"][w] - base, color=colour, ls=ls, lw=1.0, label=label)
    ax.set_ylabel("f − f before the step [Hz]")
    ax.set_xlabel("time after the load step [s]")
    ax.legend(fontsize=7)
    figures.save(ctx, fig, "f4h_programmable_h" + ("_network" if network is not None else ""),
                 "programmable H = 3 s and H = 5 s for SDViSC: a larger H decreases the nadir and the "
                 "oscillation frequency.")


def sdc_record(run_dir) -> list[dict]:
    """The SDC's SET_PARAMS records of a network run (sdc*_stats.json: sdc_command events)."""
    found = []
    for path in sorted(run_dir.glob("sdc*_stats.json")):
        events = json.loads(path.read_text()).get("events", [])
        found += [dict(e, sdc=path.stem.split("_")[0]) for e in events if e.get("cmd") == "SET_PARAMS"]
    return found


def _f4hnet(ctx: Context) -> dict[str, Finding]:
    c = ph.case()
    summary, ts = network_runs.run(ctx, ph.NAME)
    net = {"t": ts["t"], "f": ts["f_pcc_hz"]}
    applied = [e for e in sdc_record(ctx.out_dir / "runs" / ph.NAME)
               if e.get("status") == "OK" and not e.get("pending") and e.get("in_effect", {}).get("h") == c["h_after"]]
    who = sorted({e["wt"] for e in applied})
    t0 = summary["t0_wall"]  # the SDC stamps its records on the run's clock: t = t_wall − t0_wall
    delay_ms = [1000.0 * (e["t_wall"] - t0 - c["t_set"]) for e in applied]
    trips, fallbacks = summary.get("converter_trips") or {}, summary.get("fallbacks") or {}
    k = summary.get("time", {}).get("time_scale")
    a = Finding(
        f"{len(who)} of {len(c['turbines'])} SDViSCs stepped with H {c['h_after']:g} s from "
        + (f"{min(delay_ms):.1f}–{max(delay_ms):.1f} ms (simulated) after the request" if delay_ms else "never"),
        holds(set(who) == set(c["turbines"]) and not trips and not fallbacks, partly=bool(who)),
        f"the SDC's record (sdc*_stats.json, sdc_command SET_PARAMS: status OK, not pending, h in effect "
        f"{c['h_after']:g}); converter trips {trips or 'none'}, fall-backs {fallbacks or 'none'}; time scale {k}",
        {"applied": who, "delay_ms": delay_ms})
    offline = ph.run_sdc(c)
    off_ev, net_ev = ph.events_of(offline, c), ph.events_of(net, c)
    errs = [abs(n["dip_hz"] - o["dip_hz"]) / abs(o["dip_hz"]) for n, o in zip(net_ev, off_ev)]
    worst = max(errs)
    verdicts = [close_to(n["dip_hz"], o["dip_hz"], AGREE_YES, AGREE_PARTLY) for n, o in zip(net_ev, off_ev)]
    verdict = "no" if "no" in verdicts or trips or fallbacks else "partly" if "partly" in verdicts else "yes"
    ctx.numbers["f4hnet"] = {"events_network": net_ev, "events_offline": off_ev, "relative_error": errs,
                             "time_scale": k, "late_steps": summary.get("late_steps"), "steps": summary.get("steps")}
    b = Finding(
        "dips network " + ", ".join(f"{e['dip_hz']:+.4f}" for e in net_ev) + " Hz, offline "
        + ", ".join(f"{e['dip_hz']:+.4f}" for e in off_ev) + f" Hz (before, after H → {c['h_after']:g} s; worst "
        f"{worst:.1%} apart)", verdict,
        f"within {AGREE_YES:.0%} = yes, {AGREE_PARTLY:.0%} partly, each step; offline: the SDC's controller bank "
        "with one sample of round trip and its set_params at the request's time (report/programmable_h.py); "
        f"{summary.get('late_steps')} of {summary.get('steps')} steps late at time scale {k}. H's own effect "
        "(F4h.a) is smaller than this comparison resolves: it needs the control run, offline only",
        {"relative_error": errs})
    runs = {"sdc": offline, "sdc_h_kept": ph.run_sdc(c, switch=False)}
    _figure(ctx, c, runs, network=net, k=k)
    return {"F4hnet.a": a, "F4hnet.b": b}


F4H = Experiment("F4h", "Programmable H at run time: H 3 → 5 s between two +50 MW steps",
                 "Fig. Compare_inertia1 (c)", "offline", F4H_CLAIMS, _f4h, "",
                 "Offline; the SDC's controller bank and its set_params (report/programmable_h.py), a control run "
                 "with H kept, the continuous law as a cross-check; grid source H 5 s on 1000 MVA (assumed).")
F4HNET = Experiment("F4hnet", "F4h through the network: set_params {h: 5} from the OWFCC",
                    "Fig. Compare_inertia1 (c)", "cyber", F4HNET_CLAIMS, _f4hnet, network_runs.command(ph.NAME),
                    "Four SDViSCs of cluster 3 stepped by the SDC over the network at the auto time scale; the "
                    "OWFCC's set_params at 7 s; beside the same case offline.")
