"""Recovery-time benchmark of the SDN application on real Mininet + Open vSwitch + os-ken.

Prints one JSON object: percentiles of the recovery time (link down → first control packet at the
turbine over the new path) over many link failures at different places of the ``paper`` and
``farm`` topologies, for each rerouting mechanism (AK/DR, port status), and of the SDC failover
time (primary killed → first control packet from the backup). Needs root; takes several minutes.

    python benchmarks/recovery.py [--failures 16] [--failover-runs 10] [--out DIR]

Each run plays one scenario with ``--failures`` failures: every 0.6 s a switch-to-switch link of
the path currently carrying one of the ViSC turbines fails (``path_link_down``, cycling over
turbines and hops) and is restored 0.3 s later.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import liveness_soak  # benchmarks/liveness_soak.py, beside this file
import numpy as np
from scenario_runs import run_dict as run  # benchmarks/scenario_runs.py

GOALS = {"dr_p95_ms": 50.0, "ff_p95_ms": 5.0, "failover_p95_ms": 60.0}
TOPOLOGIES = {
    "paper": ({"name": "paper", "clusters": 2, "turbines": 2}, ["wt1_1", "wt2_2"]),
    "farm": ({"name": "farm", "clusters": 5, "turbines": 10, "layout": "compact"}, ["wt1_1", "wt4_5"]),
}
MECHANISMS = {
    "dr": {"dynamic_routing": True, "reroute_on_port_status": False},
    "port_status": {"dynamic_routing": True, "reroute_on_port_status": True},
    "ff": {"dynamic_routing": True, "reroute_on_port_status": False, "fast_failover": True},
}


def failure_scenario(name: str, topo: dict, turbines: list[str], sdn: dict, failures: int) -> dict:
    timeline = [{"t": 0.5 + 0.1 * i, "do": "visc_on", "wt": wt} for i, wt in enumerate(turbines)]
    t = 1.5
    for i in range(failures):
        wt = turbines[i % len(turbines)]
        hop = (i // len(turbines)) % 3
        timeline.append({"t": round(t, 3), "do": "path_link_down", "wt": wt, "hop": hop})
        timeline.append({"t": round(t + 0.3, 3), "do": "restore_links"})
        t += 0.6
    return {"name": name, "topology": topo, "duration_s": round(t + 0.3, 3), "plant": {"model": "minimal"},
            "sdc": {"method": "tustin", "backup": False}, "sdn": sdn, "timeline": timeline}


def failover_scenario(name: str) -> dict:
    return {"name": name, "topology": {"name": "paper", "clusters": 1, "turbines": 1}, "duration_s": 2.5,
            "plant": {"model": "minimal"}, "sdc": {"method": "tustin", "backup": True},
            "sdn": {"failover": True},
            "timeline": [{"t": 0.5, "do": "visc_on", "wt": "wt1_1"}, {"t": 1.5, "do": "kill", "host": "sdc1",
                                                                        "process": "sdc"}]}


def targeted_interruptions(summary: dict) -> list[float]:
    """For each path failure: how long the targeted turbine's control packets stopped, from the
    failure to the next control packet (gaps shorter than the plant's 5 ms gap threshold count as
    5 ms, an upper bound)."""
    out = []
    for e in summary["events"]:
        if e.get("source") != "timeline" or e.get("requested") != "path_link_down":
            continue
        t_f = e["t_effective"]
        gaps = summary["turbines"].get(e["wt"], {}).get("ctrl_gaps", [])
        hit = [b for a, b in gaps if t_f - 0.01 <= a <= t_f + 0.1 and b >= t_f]
        out.append((max(hit) - t_f) * 1e3 if hit else 5.0)
    return out


def percentiles(values: list[float]) -> dict:
    if not values:
        return {"n": 0}
    a = np.asarray(values)
    return {"n": int(a.size), "p50": float(np.percentile(a, 50)), "p95": float(np.percentile(a, 95)),
            "max": float(a.max()), "min": float(a.min())}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--failures", type=int, default=16,
                        help="link failures per (topology, mechanism) run (0: SDC failover runs only)")
    parser.add_argument("--failover-runs", type=int, default=10)
    parser.add_argument("--out", help="keep the runs' results here (default: a temporary directory)")
    parser.add_argument("--soak-runs", type=int, default=0,
                        help="also this many fault-free runs per case of benchmarks/liveness_soak.py (false positives)")
    parser.add_argument("--soak-duration", type=float, default=60.0)
    args = parser.parse_args(argv)
    if os.geteuid() != 0:
        print("benchmarks/recovery.py needs root (Mininet)", file=sys.stderr)
        return 2
    work = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="sdvisc-recovery-"))
    work.mkdir(parents=True, exist_ok=True)
    started = time.time()
    result: dict = {"benchmark": "recovery", "failures_per_run": args.failures, "runs": {}}
    samples: dict[str, list[float]] = {m: [] for m in MECHANISMS}
    detect: dict[str, list[float]] = {"dr": [], "sdc_failover": []}
    unrecovered: dict[str, int] = {m: 0 for m in MECHANISMS}
    for topo_name, (topo, turbines) in (TOPOLOGIES.items() if args.failures > 0 else ()):
        for mech, sdn in MECHANISMS.items():
            name = f"recovery_{topo_name}_{mech}"
            summary = run(failure_scenario(name, topo, turbines, sdn, args.failures), work)
            recs = summary["recoveries"]
            times = [r["recovery_ms"] for r in recs if r["recovery_ms"] is not None]
            detect["dr"] += [r["detect_ms"] for r in recs if r["cause"] == "dr" and r["detect_ms"] is not None]
            if mech == "ff":
                times = targeted_interruptions(summary)
            samples[mech] += times
            unrecovered[mech] += sum(r["recovery_ms"] is None for r in recs)
            faults = sum(e["type"] == "link_down" and e.get("source") == "timeline" for e in summary["events"])
            result["runs"][name] = {"faults": faults, "recoveries": len(recs), "recovered": len(times),
                                    "causes": sorted({r["cause"] for r in recs}), "late_steps": summary["late_steps"],
                                    **{k: v for k, v in percentiles(times).items() if k != "n"}}
    failover = []
    for i in range(args.failover_runs):
        summary = run(failover_scenario(f"failover_{i}"), work)
        failover += [r["recovery_ms"] for r in summary["recoveries"] if r["recovery_ms"] is not None]
        detect["sdc_failover"] += [r["detect_ms"] for r in summary["recoveries"]
                                   if r["cause"] == "sdc_failover" and r["detect_ms"] is not None]
    for mech in MECHANISMS:
        stats = percentiles(samples[mech])
        result[f"{mech}_ms"] = stats
        result[f"{mech}_unrecovered"] = unrecovered[mech]
    result["dr_p95_ms"] = result["dr_ms"].get("p95")
    result["failover_runs"] = args.failover_runs
    result["port_status_p95_ms"] = result["port_status_ms"].get("p95")
    result["ff_p95_ms"] = result["ff_ms"].get("p95")
    result["ff_note"] = ("with fast-failover groups, failures the data plane repairs are interruptions shorter "
                         "than 20 ms and may not register as recoveries; ff_unrecovered and the per-run fault "
                         "counts say how many failures did")
    result["failover_ms"] = percentiles(failover)
    result["failover_p95_ms"] = result["failover_ms"].get("p95")
    result["detect_ms"] = {k: percentiles(v) for k, v in detect.items()}  # fault → the app's decision
    if args.soak_runs:
        soak = {}
        for case in ("paper", "farm4"):
            runs = [liveness_soak.count(run(dict(liveness_soak.case(case, args.soak_duration),
                                                 name=f"soak_{case}_{i}"), work)) for i in range(args.soak_runs)]
            soak[case] = {k: sum(r[k] for r in runs) for k in liveness_soak.FALSE_EVENTS}
        result["false_positives"] = {"runs_per_case": args.soak_runs, "duration_s": args.soak_duration, **soak}
    result["goals"] = GOALS
    result["machine"] = {"platform": platform.platform(), "cpus": os.cpu_count(), "python": platform.python_version()}
    result["wall_s"] = round(time.time() - started, 1)
    result["results_dir"] = str(work)
    print(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
