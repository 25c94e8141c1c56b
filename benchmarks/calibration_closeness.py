"""How close each candidate k of ``--time-scale auto`` came, and whether the run at the chosen k held
(issue 42 item 6: all_visc_50's auto should pick k ≤ 8 and hold).

Runs ``sdvisc run SCENARIO --time-scale auto --recalibrate`` (calibration cache off) ``--runs`` times,
optionally with ovs-vswitchd's main thread at SCHED_FIFO for the run (``--ovs-fifo``: the A/B of the
switch's scheduling; restored after each run), or only reads back run directories already made
(``--from DIR …``). Prints one JSON object: per run, every candidate's closeness
(``time.calibration.candidates``), the pilot's plant step and SDC busy fraction, the run's worst
turbine within one sample and late steps at the chosen k, CPU per plant step per process, the load
before and after. Needs root for runs, and the network lock:

    flock /tmp/sdvisc-net.lock env SDVISC_NETWORK_LOCK_HELD=1 python benchmarks/calibration_closeness.py \\
        [--scenario all_visc_50] [--duration 2] [--runs 1] [--calibrate-from 4] [--ovs-fifo] [--out DIR]
    python benchmarks/calibration_closeness.py --from /tmp/a /tmp/b [--label base --label fifo]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # benchmarks/

from scenario_runs import ROOT, finish, machine, work_dir  # noqa: E402
from time_scale import judge  # noqa: E402


def read_run(out: Path) -> dict:
    """The figures of one run directory (its summary.json)."""
    s = json.loads((out / "summary.json").read_text())
    cal = s["time"].get("calibration") or {}
    verdict = judge(s)
    verdict.pop("within_one_sample")
    within = [t["round_trip_samples"]["within_one"] for t in s["turbines"].values()
              if (t.get("round_trip_samples") or {}).get("within_one") is not None]
    return {"dir": str(out), "chosen_k": s["time"]["time_scale"], "calibration_wall_s": cal.get("wall_s"),
            "plant_scheduling": cal.get("plant_scheduling"), "candidates": cal.get("candidates"),
            "trials": [{"k": t["k"], "ok": t["ok"], "plant_step_us": t["plant_step_us"], "sdc_busy": t["sdc_busy"],
                        "answer_p99_sim_ms": t["answer_p99_sim_ms"], "steps": t["steps"]}
                       for t in cal.get("trials", [])],
            "run": {**verdict, "median_within_one_sample": sorted(within)[len(within) // 2] if within else None,
                    "late_steps": s["late_steps"], "steps": s["steps"]}}


def run_once(args, out: Path) -> dict:
    cmd = [sys.executable, "-m", "scenarios.cli", "run", str(ROOT / "scenarios" / f"{args.scenario}.yaml"),
           "--time-scale", "auto", "--recalibrate", "--duration", str(args.duration), "--out", str(out), "--quiet"]
    if args.calibrate_from:
        cmd += ["--calibrate-from", str(args.calibrate_from)]
    env = {**os.environ, "SDVISC_CALIBRATION_CACHE": "none"}
    ovs = None
    if args.ovs_fifo:
        ovs = subprocess.run(["pgrep", "-x", "ovs-vswitchd"], capture_output=True, text=True).stdout.split()[0]
        subprocess.run(["chrt", "-f", "-p", "5", ovs], check=True)
    load_before = os.getloadavg()
    try:
        res = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=1800)
    finally:
        if ovs is not None:
            subprocess.run(["chrt", "-o", "-p", "0", ovs], check=False)
    if res.returncode != 0:
        raise RuntimeError(f"run failed:\n{res.stdout[-2000:]}\n{res.stderr[-2000:]}")
    return {**read_run(out), "ovs_main_thread": "SCHED_FIFO:5" if ovs else "SCHED_OTHER",
            "load_before": load_before, "load_after": os.getloadavg()}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenario", default="all_visc_50")
    ap.add_argument("--duration", type=float, default=2.0, help="simulated seconds of each run")
    ap.add_argument("--runs", type=int, default=1)
    ap.add_argument("--calibrate-from", type=float, default=4, help="first candidate (0: the calibration's own guess)")
    ap.add_argument("--ovs-fifo", action="store_true", help="ovs-vswitchd's main thread at SCHED_FIFO 5 during each run")
    ap.add_argument("--from", dest="dirs", nargs="*", type=Path, help="only read these run directories")
    ap.add_argument("--label", action="append", default=[], help="a label per --from directory")
    ap.add_argument("--out", type=Path)
    args = ap.parse_args(argv)
    if args.dirs:
        runs = [{"label": label, **read_run(d)} for d, label in zip(args.dirs, args.label + [None] * len(args.dirs))]
        return finish({"benchmark": "calibration closeness (read back)", "runs": runs, "machine": machine()})
    work = work_dir(args.out, "sdvisc-closeness-")
    result = {"benchmark": "calibration closeness", "scenario": args.scenario, "duration_s": args.duration,
              "load_before": os.getloadavg(), "runs": []}
    for n in range(args.runs):
        result["runs"].append(run_once(args, work / f"run{n}"))
    return finish(result)


if __name__ == "__main__":
    sys.exit(main())
