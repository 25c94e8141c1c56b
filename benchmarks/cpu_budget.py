"""CPU per ViSC sample: what each process of the testbed spends per plant step (Ts) with 1, 4 and
16 ViSC turbines on the farm network — it sets how small the time scale can be.

Prints one JSON object. Each case runs the farm topology (5 × 10, compact), N turbines switched
to SDViSC at t = 0.5 s (spread over the clusters), for ``--duration`` simulated seconds at time
scale ``--time-scale``; ``summary.json`` → ``cpu`` has each process's CPU seconds from t = 0 to
the end (/proc utime + stime; start-up compiles left out): the plant, each SDC, the SDN app(s),
the OWFCC and ovs-vswitchd (all switches). Per sample = per plant step. Needs root.

    python benchmarks/cpu_budget.py [--turbines 1,4,16] [--duration 10] [--time-scale 4] [--plant full]
                                    [--switch-ports system|afxdp|afxdp-nonpmd] [--switch-links veth|patch] [--cpu-split on|off]

``total_us`` adds ovs-vswitchd: at time scale 1 the machine holds the run only while it is below
``cpus`` × Ts (``fits_cores`` = total / Ts, the cores the run needs at k = 1).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

from scenario_runs import machine, run_dict  # benchmarks/scenario_runs.py

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from scenarios.switch_links import SWITCH_LINK_KINDS  # noqa: E402
from scenarios.switch_ports import SWITCH_PORT_TYPES  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
GOALS_US = {"sdc_fixed_per_round": 50.0, "plant_step_remote": 30.0, "chain_outside_switches": 100.0}


def scenario(n: int, duration: float, time_scale: float, plant: str) -> dict:
    wts = [f"wt{1 + i % 5}_{1 + i // 5}" for i in range(n)]
    return {"name": f"cpu_{n}visc", "topology": {"name": "farm", "clusters": 5, "turbines": 10, "layout": "compact"},
            "duration_s": duration, "time_scale": time_scale, "plant": {"model": plant},
            "sdc": {"method": "tustin", "backup": False},
            "timeline": [{"t": round(0.5 + 0.01 * i, 3), "do": "visc_on", "wt": wt} for i, wt in enumerate(wts)]}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--turbines", default="1,4,16")
    ap.add_argument("--duration", type=float, default=10.0)
    ap.add_argument("--time-scale", type=float, default=4.0)
    ap.add_argument("--plant", choices=["full", "minimal"], default="full")
    ap.add_argument("--switch-ports", choices=SWITCH_PORT_TYPES, default="system")
    ap.add_argument("--switch-links", choices=SWITCH_LINK_KINDS, default="veth")
    ap.add_argument("--cpu-split", choices=("on", "off"), default="off")
    ap.add_argument("--out", type=Path)
    args = ap.parse_args()
    if os.geteuid() != 0:
        raise SystemExit("needs root")
    work = args.out or Path(tempfile.mkdtemp(prefix="sdvisc-cpu-"))
    work.mkdir(parents=True, exist_ok=True)
    result: dict = {"benchmark": "cpu_budget", "plant": args.plant, "time_scale": args.time_scale,
                    "duration_s": args.duration, "switch_ports": args.switch_ports, "switch_links": args.switch_links,
                    "cpu_split": args.cpu_split, "cpus": os.cpu_count(), "load_before": os.getloadavg(),
                    "goals_us": GOALS_US, "cases": {}}
    started = time.time()
    for n in (int(x) for x in args.turbines.split(",")):
        s = run_dict(scenario(n, args.duration, args.time_scale, args.plant), work,
                     "--switch-ports", args.switch_ports, "--switch-links", args.switch_links,
                     "--cpu-split", args.cpu_split)
        cpu = s.get("cpu", {})
        per = {name: v["us_per_step"] for name, v in cpu.items()}
        chain = sum(v for name, v in per.items() if name != "ovs-vswitchd")
        total = chain + per.get("ovs-vswitchd", 0.0)
        step_us = s["step_s"] * 1e6
        result["cases"][f"{n}_visc"] = {
            "us_per_sample": per, "chain_outside_switches_us": round(chain, 2),
            "total_us": round(total, 2), "cores_needed_at_k1": round(total / step_us, 2),
            "late_steps": s["late_steps"], "steps": s["steps"],
            "ctrl_delivered": {wt: round(t["packets"]["ctrl_rx"] / max(1, t["packets"]["meas_tx"]), 4)
                               for wt, t in s["turbines"].items()}}
    result["wall_s"] = round(time.time() - started, 1)
    result["load_after"] = os.getloadavg()
    result["machine"] = machine()
    print(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
