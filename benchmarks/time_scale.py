"""The smallest time scale at which a scenario holds on this machine, and what ``--time-scale auto``
picks for it: fewer than 1 % late plant steps and, for every ViSC turbine, at least 99 % of the
control answers applied within one sample of their MEAS (summary.json → round_trip_samples,
counted by the plant per CTRL) and no converter trip.

Prints one JSON object: per scenario, each k tried (1, 2, 4, … up to --max) with its late-step
fraction, round trip, control packets delivered and CPU per step; ``min_time_scale`` (None if none up
to --max holds); with ``--auto`` also one run at ``--time-scale auto``: the k its calibration chose,
whether that run held, and ``auto_at_least_min`` (auto never picks a k below the measured minimum).
Needs root. Defaults: ``fault_4visc_network`` and ``all_visc_50``.

    python benchmarks/time_scale.py [--scenarios fault_4visc_network,all_visc_50] [--start 1] [--max 64] [--auto]
        [--switch-links veth|patch] [--cpu-split on|off] [--compare-cpu-split N]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

from scenario_runs import ROOT, finish, run_file, work_dir  # benchmarks/scenario_runs.py

LATE_MAX = 0.01
WITHIN_ONE_MIN = 0.99


def judge(s: dict) -> dict:
    within = {wt: (t.get("round_trip_samples") or {}).get("within_one") for wt, t in s["turbines"].items()}
    worst = min((v for v in within.values() if v is not None), default=None)
    late = s["late_steps"] / s["steps"] if s["steps"] else 1.0
    delivered = [t["packets"]["ctrl_rx"] / max(1, t["packets"]["meas_tx"]) for t in s["turbines"].values()
                 if t["packets"]["meas_tx"]]
    trips = sum(s.get("converter_trips", {}).values())
    return {"late_fraction": round(late, 4), "worst_within_one_sample": worst, "within_one_sample": within,
            "converter_trips": trips, "min_ctrl_delivered": round(min(delivered), 4) if delivered else None,
            "wall_s": s["time"]["wall_duration_s"], "cpu_us_per_step": {n: v["us_per_step"] for n, v in s["cpu"].items()},
            "holds": late < LATE_MAX and worst is not None and worst >= WITHIN_ONE_MIN and not trips}


def smallest_time_scale(name: str, work: Path, start: float = 1.0, largest: float = 64.0,
                        extra: tuple[str, ...] = ()) -> tuple[float | None, dict]:
    """The smallest k of start, 2·start, … largest at which ``scenarios/<name>.yaml`` holds
    (:func:`judge`), and the verdict of every k tried; None if none does. ``extra``: more
    ``sdvisc run`` options."""
    tried: dict = {}
    k = start
    while k <= largest:
        verdict = judge(run_file(ROOT / "scenarios" / f"{name}.yaml", work / f"{name}_k{k:g}", "--time-scale", f"{k:g}",
                                 *extra))
        tried[f"{k:g}"] = verdict
        if verdict["holds"]:
            return k, tried
        k *= 2
    return None, tried


def compare_cpu_split(name: str, work: Path, k: float, pairs: int, extra: tuple[str, ...]) -> dict:
    """``pairs`` runs of ``scenarios/<name>.yaml`` at time scale ``k`` with cpu_split on and as many
    with it off, alternated (the machine's load drifts): each verdict, and how many held."""
    runs: dict[str, list] = {"on": [], "off": []}
    for i in range(pairs):
        for split in ("on", "off"):
            s = run_file(ROOT / "scenarios" / f"{name}.yaml", work / f"{name}_split_{split}_{i}",
                         "--time-scale", f"{k:g}", "--cpu-split", split, *extra)
            verdict = judge(s)
            verdict.pop("within_one_sample")
            runs[split].append({**verdict, "load": round(os.getloadavg()[0], 2)})
    return {"time_scale": k, "runs": runs,
            "held": {split: sum(r["holds"] for r in rs) for split, rs in runs.items()},
            "worst_within_one_sample": {split: [r["worst_within_one_sample"] for r in rs] for split, rs in runs.items()}}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenarios", default="fault_4visc_network,all_visc_50")
    ap.add_argument("--auto", action="store_true", help="also run once at --time-scale auto and compare")
    ap.add_argument("--start", type=float, default=1.0)
    ap.add_argument("--max", type=float, default=64.0)
    ap.add_argument("--switch-links", choices=("veth", "patch"), help="override the scenarios' switch_links")
    ap.add_argument("--cpu-split", choices=("on", "off"), help="override the scenarios' cpu_split")
    ap.add_argument("--compare-cpu-split", type=int, default=0, metavar="N",
                    help="instead: N pairs of runs at --start, cpu_split on then off (each scenario), "
                         "with each run's verdict and how many held per arrangement")
    ap.add_argument("--out", type=Path)
    args = ap.parse_args()
    links = ("--switch-links", args.switch_links) if args.switch_links else ()
    extra = links + (("--cpu-split", args.cpu_split) if args.cpu_split else ())
    work = work_dir(args.out, "sdvisc-timescale-")
    result: dict = {"benchmark": "time_scale", "cpus": os.cpu_count(), "load_before": os.getloadavg(),
                    "criteria": {"late_fraction_below": LATE_MAX, "within_one_sample_at_least": WITHIN_ONE_MIN,
                                 "converter_trips": 0},
                    "options": list(extra), "scenarios": {}}
    started = time.time()
    for name in args.scenarios.split(",") if not args.compare_cpu_split else ():
        found, tried = smallest_time_scale(name, work, args.start, args.max, extra)
        result["scenarios"][name] = {"min_time_scale": found, "tried": tried}
        if args.auto:
            s = run_file(ROOT / "scenarios" / f"{name}.yaml", work / f"{name}_auto", "--time-scale", "auto", *extra)
            cal = s["time"]["calibration"]
            result["scenarios"][name]["auto"] = {
                "time_scale": cal["time_scale"], "met": cal["met"], "calibration_wall_s": cal["wall_s"],
                "trials": [{k: t[k] for k in ("k", "plant_busy", "sdc_busy", "answer_p99_sim_ms", "ok")}
                           for t in cal["trials"]],
                "run": judge(s), "auto_at_least_min": found is not None and cal["time_scale"] >= found}
    if args.compare_cpu_split:
        for name in args.scenarios.split(","):  # --cpu-split is what the comparison varies
            result["scenarios"][name] = compare_cpu_split(name, work, args.start, args.compare_cpu_split, links)
    result["wall_s"] = round(time.time() - started, 1)
    return finish(result)


if __name__ == "__main__":
    sys.exit(main())
