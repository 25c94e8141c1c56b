"""The smallest time scale at which a scenario holds on this machine: fewer than 1 % late plant
steps and every ViSC turbine's MEAS→CTRL round trip within one sample (p99 of the MEAS one-way
delay at the SDC plus p99 of the CTRL one-way delay at the turbine, in simulated time).

Prints one JSON object: per scenario, each k tried (1, 2, 4, … up to --max) with its late-step
fraction, worst round trip in samples and control packets delivered, and ``min_time_scale``
(None if none up to --max holds). Needs root. Defaults: ``plant_rt_4visc`` and ``all_visc_50``
(issue "Virtual time": min_time_scale_4visc, min_time_scale_50visc).

    python benchmarks/time_scale.py [--scenarios plant_rt_4visc,all_visc_50] [--start 1] [--max 64]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

from scenario_runs import ROOT, machine, run_file  # benchmarks/scenario_runs.py

LATE_MAX = 0.01
ROUND_TRIP_MAX_SAMPLES = 1.0


def judge(s: dict) -> dict:
    step_ms = s["step_s"] * 1e3
    trips = {}
    for wt, t in s["turbines"].items():
        d = t["one_way_delay_ms"]
        meas, ctrl = (d.get("meas_to_sdc") or {}).get("p99"), (d.get("ctrl_to_turbine") or {}).get("p99")
        trips[wt] = round((meas + ctrl) / step_ms, 3) if meas is not None and ctrl is not None else None
    worst = max((v for v in trips.values() if v is not None), default=None)
    late = s["late_steps"] / s["steps"] if s["steps"] else 1.0
    delivered = [t["packets"]["ctrl_rx"] / max(1, t["packets"]["meas_tx"]) for t in s["turbines"].values()
                 if t["packets"]["meas_tx"]]
    return {"late_fraction": round(late, 4), "worst_round_trip_samples": worst, "round_trip_samples": trips,
            "min_ctrl_delivered": round(min(delivered), 4) if delivered else None,
            "wall_s": s["time"]["wall_duration_s"], "cpu_us_per_step": {n: v["us_per_step"] for n, v in s["cpu"].items()},
            "holds": late < LATE_MAX and worst is not None and worst <= ROUND_TRIP_MAX_SAMPLES}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenarios", default="plant_rt_4visc,all_visc_50")
    ap.add_argument("--start", type=float, default=1.0)
    ap.add_argument("--max", type=float, default=64.0)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args()
    if os.geteuid() != 0:
        raise SystemExit("needs root")
    work = args.out or Path(tempfile.mkdtemp(prefix="sdvisc-timescale-"))
    work.mkdir(parents=True, exist_ok=True)
    result: dict = {"benchmark": "time_scale", "cpus": os.cpu_count(), "load_before": os.getloadavg(),
                    "criteria": {"late_fraction_below": LATE_MAX, "round_trip_samples_at_most": ROUND_TRIP_MAX_SAMPLES},
                    "scenarios": {}}
    started = time.time()
    for name in args.scenarios.split(","):
        tried, found, k = {}, None, args.start
        while k <= args.max:
            verdict = judge(run_file(ROOT / "scenarios" / f"{name}.yaml", work / f"{name}_k{k:g}",
                                     "--time-scale", f"{k:g}"))
            tried[f"{k:g}"] = verdict
            if verdict["holds"]:
                found = k
                break
            k *= 2
        result["scenarios"][name] = {"min_time_scale": found, "tried": tried}
    result["wall_s"] = round(time.time() - started, 1)
    result["load_after"] = os.getloadavg()
    result["machine"] = machine()
    print(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
