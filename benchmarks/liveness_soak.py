"""Fault-free soak of the SDN application's detectors: false SDC deaths, spurious failovers and
spurious DRs when nothing fails.

Prints one JSON object. Each run plays a scenario with no fault at all (ViSC turbines switched on
early, then left alone) and counts, from ``summary.json``'s events: ``sdc_dead`` (false: no SDC
was killed), ``sdc_failover`` (spurious), DR reroutes (``dr``) and ``dr_not_acted`` (spurious: no
link failed), ``sdc_suspect`` (suspicions that were *not* turned into a decision, for information)
and ``no_path``. Needs root; each run takes its duration plus ~15 s of set-up.

    python benchmarks/liveness_soak.py [--runs 10] [--duration 60] [--cases paper,farm4] [--out DIR]

The true-failure side of the same detectors (detection time of a killed SDC and of a failed link)
is measured by ``benchmarks/recovery.py``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

from scenario_runs import run_dict  # benchmarks/scenario_runs.py

FALSE_EVENTS = ("sdc_dead", "sdc_failover", "dr", "dr_not_acted", "failover_unavailable", "no_path")
INFO_EVENTS = ("sdc_suspect", "sdc_alive", "service_restarted")


def case(name: str, duration_s: float) -> dict:
    if name == "paper":  # one ViSC turbine, backup SDC with mirrored measurements (issue 13's case)
        return {"name": "soak_paper", "topology": {"name": "paper", "clusters": 1, "turbines": 2},
                "duration_s": duration_s, "plant": {"model": "minimal"},
                "sdc": {"method": "tustin", "backup": True}, "sdn": {"failover": True},
                "timeline": [{"t": 0.5, "do": "visc_on", "wt": "wt1_1"}]}
    if name == "farm4":  # four ViSC turbines, one per cluster, on the 5 x 10 farm network
        wts = ["wt1_1", "wt2_1", "wt3_1", "wt4_1"]
        return {"name": "soak_farm4", "topology": {"name": "farm", "clusters": 5, "turbines": 10, "layout": "compact"},
                "duration_s": duration_s, "plant": {"model": "minimal"},
                "sdc": {"method": "tustin", "backup": False}, "sdn": {"failover": True},
                "timeline": [{"t": 0.5 + 0.1 * i, "do": "visc_on", "wt": wt} for i, wt in enumerate(wts)]}
    raise SystemExit(f"unknown case {name!r} (paper, farm4)")


def count(summary: dict) -> dict:
    kinds = Counter(e.get("type") for e in summary.get("events", []))
    out = {k: kinds.get(k, 0) for k in FALSE_EVENTS + INFO_EVENTS}
    turbines = summary.get("turbines", {})
    out["ctrl_rx_over_meas_tx"] = {wt: round(p["packets"]["ctrl_rx"] / max(1, p["packets"]["meas_tx"]), 4)
                                   for wt, p in turbines.items() if p.get("packets", {}).get("meas_tx")}
    out["late_steps"] = summary.get("late_steps")
    out["steps"] = summary.get("steps")
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--cases", default="paper,farm4")
    ap.add_argument("--out", type=Path, default=None, help="keep each run's results here")
    args = ap.parse_args()
    if os.geteuid() != 0:
        raise SystemExit("needs root")
    work = args.out or Path(tempfile.mkdtemp(prefix="sdvisc-soak-"))
    work.mkdir(parents=True, exist_ok=True)
    result: dict = {"benchmark": "liveness_soak", "host": platform.node(), "cpus": os.cpu_count(),
                    "load_before": os.getloadavg(), "runs": args.runs, "duration_s": args.duration, "cases": {}}
    t_start = time.time()
    for name in args.cases.split(","):
        per_run = []
        for i in range(args.runs):
            sc = case(name, args.duration)
            sc["name"] = f"{sc['name']}_{i}"
            per_run.append(count(run_dict(sc, work)))
        totals = {k: sum(r[k] for r in per_run) for k in FALSE_EVENTS + INFO_EVENTS}
        result["cases"][name] = {"totals": totals, "runs": per_run,
                                 "false_total": sum(totals[k] for k in FALSE_EVENTS)}
    result["wall_s"] = round(time.time() - t_start, 1)
    result["load_after"] = os.getloadavg()
    print(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
