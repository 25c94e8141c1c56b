"""CPU per ViSC sample: what each process of the testbed spends per plant step (Ts) with 1, 4, 16
and 50 ViSC turbines on the farm network — it sets how small the time scale can be.

Prints one JSON object. Each case runs the farm topology (5 × 10, compact), N turbines switched
to SDViSC at t = 0.5 s (spread over the clusters), for ``--duration`` simulated seconds at time
scale ``--time-scale``; ``summary.json`` → ``cpu`` has each process's CPU seconds from t = 0 to
the end (/proc utime + stime; start-up compiles left out): the plant, each SDC, the SDN app(s),
the OWFCC and ovs-vswitchd (all switches). Per sample = per plant step. Needs root.

    python benchmarks/cpu_budget.py [--turbines 1,4,16,50] [--duration 10] [--time-scale 4[,4,8,16]] [--plant full]
                                    [--switch-ports system|afxdp|afxdp-nonpmd] [--switch-links veth|patch] [--cpu-split on|off]
                                    [--switch-revalidation-ms MS] [--sdn-intake auto|socket|packet_in]

``--time-scale`` takes one k for every case or one per case. ``total_us`` adds ovs-vswitchd: at time
scale 1 the machine holds the run only while it is below ``cpus`` × Ts (``fits_cores`` = total / Ts,
the cores the run needs at k = 1). ``per_visc_sample_us``: each process's and the total per plant
step divided by the ViSC count — the figure issue 32 asks to cut. ``sdn_app_us_per_report``: the SDN
app's CPU divided by the AKs and heartbeats it took in (its whole CPU, timer and state publishing
included: an upper bound of its intake cost).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

from scenario_runs import finish, run_dict, work_dir  # benchmarks/scenario_runs.py

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from scenarios.switch_links import SWITCH_LINK_KINDS  # noqa: E402
from scenarios.switch_ports import SWITCH_PORT_TYPES  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
GOALS_US = {"sdc_fixed_per_round": 50.0, "plant_step_remote": 30.0, "chain_outside_switches": 100.0}


def scenario(n: int, duration: float, time_scale: float, plant: str, revalidation_ms: int | None = None,
             intake: str = "auto") -> dict:
    wts = [f"wt{1 + i % 5}_{1 + i // 5}" for i in range(n)]
    sc = {"name": f"cpu_{n}visc", "topology": {"name": "farm", "clusters": 5, "turbines": 10, "layout": "compact"},
          "duration_s": duration, "time_scale": time_scale, "plant": {"model": plant},
          "sdc": {"method": "tustin", "backup": False}, "sdn": {"intake": intake},
          "timeline": [{"t": round(0.5 + 0.01 * i, 3), "do": "visc_on", "wt": wt} for i, wt in enumerate(wts)]}
    if revalidation_ms:
        sc["switch_revalidation_ms"] = revalidation_ms
    return sc


def case_figures(s: dict, n: int) -> dict:
    """The figures of one case from its ``summary.json``."""
    per = {name: v["us_per_step"] for name, v in s.get("cpu", {}).items()}
    chain = sum(v for name, v in per.items() if name != "ovs-vswitchd")
    total = chain + per.get("ovs-vswitchd", 0.0)
    step_us = s["step_s"] * 1e6
    sdn = s.get("sdn_counters", {})
    reports = sdn.get("ak_rx", 0) + sdn.get("heartbeats", 0)
    app_s = s.get("cpu", {}).get("controller", {}).get("cpu_s")
    within = {wt: (t.get("round_trip_samples") or {}).get("within_one") for wt, t in s["turbines"].items()}
    within = {wt: v for wt, v in within.items() if v is not None}
    return {"us_per_sample": per, "chain_outside_switches_us": round(chain, 2),
            "total_us": round(total, 2), "cores_needed_at_k1": round(total / step_us, 2),
            "per_visc_sample_us": ({name: round(v / n, 2) for name, v in per.items()} | {"total": round(total / n, 2)})
            if n else None,
            "sdn_app_us_per_report": round(app_s * 1e6 / reports, 1) if app_s and reports else None,
            "sdn_reports": {"ak_rx": sdn.get("ak_rx", 0), "heartbeats": sdn.get("heartbeats", 0),
                            "via_intake_socket": sdn.get("intake_rx", 0), "via_packet_in": sdn.get("packet_in", 0)},
            "late_steps": s["late_steps"], "steps": s["steps"],
            "worst_within_one_sample": min(within.values()) if within else None,
            "ctrl_delivered": {wt: round(t["packets"]["ctrl_rx"] / max(1, t["packets"]["meas_tx"]), 4)
                               for wt, t in s["turbines"].items()}}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--turbines", default="1,4,16,50")
    ap.add_argument("--duration", type=float, default=10.0)
    ap.add_argument("--time-scale", default="4", help="one k, or one per --turbines entry")
    ap.add_argument("--switch-revalidation-ms", type=int, default=None)
    ap.add_argument("--sdn-intake", choices=("auto", "socket", "packet_in"), default="auto")
    ap.add_argument("--plant", choices=["full", "minimal"], default="full")
    ap.add_argument("--switch-ports", choices=SWITCH_PORT_TYPES, default="system")
    ap.add_argument("--switch-links", choices=SWITCH_LINK_KINDS, default="veth")
    ap.add_argument("--cpu-split", choices=("on", "off"), default="off")
    ap.add_argument("--out", type=Path)
    args = ap.parse_args()
    work = work_dir(args.out, "sdvisc-cpu-")
    result: dict = {"benchmark": "cpu_budget", "plant": args.plant, "time_scale": args.time_scale,
                    "sdn_intake": args.sdn_intake, "switch_revalidation_ms": args.switch_revalidation_ms,
                    "duration_s": args.duration, "switch_ports": args.switch_ports, "switch_links": args.switch_links,
                    "cpu_split": args.cpu_split, "cpus": os.cpu_count(), "load_before": os.getloadavg(),
                    "goals_us": GOALS_US, "cases": {}}
    started = time.time()
    counts = [int(x) for x in args.turbines.split(",")]
    scales = [float(x) for x in args.time_scale.split(",")]
    if len(scales) not in (1, len(counts)):
        raise SystemExit("--time-scale: one k, or one per --turbines entry")
    scales = scales * len(counts) if len(scales) == 1 else scales
    for n, k in zip(counts, scales, strict=True):
        s = run_dict(scenario(n, args.duration, k, args.plant, args.switch_revalidation_ms, args.sdn_intake), work,
                     "--switch-ports", args.switch_ports, "--switch-links", args.switch_links,
                     "--cpu-split", args.cpu_split)
        result["cases"][f"{n}_visc"] = {"time_scale": k, **case_figures(s, n)}
    result["wall_s"] = round(time.time() - started, 1)
    return finish(result)


if __name__ == "__main__":
    sys.exit(main())
