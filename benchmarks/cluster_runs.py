"""all_visc_50 on one box and on two stand-in servers (issue 30; docs/cluster.md): what spreading the
farm's switches and SDCs over servers costs on this machine.

Three runs of the 50-SDViSC farm, each at ``--time-scale auto`` measured afresh (``--recalibrate``):

* ``one_box``: ``scenarios/all_visc_50.yaml`` as shipped (patch switch links, Open vSwitch
  revalidation spaced to 10 s, CPU split);
* ``one_box_veth``: the same without the settings a run across servers does not take (veth links,
  Open vSwitch's own revalidation; CPU split kept) — the like-for-like baseline;
* ``two_servers``: ``one_box_veth`` with ``cluster: {emulate: 2}`` (by role: the seven OpenFlow
  switches and the SDCs on two stand-in servers with their own ``ovs-vswitchd``, the turbines, plant,
  SDN app and OWFCC on this machine; every turbine's link and every link between the servers a VXLAN
  tunnel).

For each: the calibrated k and its cost before t = 0, late steps, the worst turbine's answers within
one sample, the MEAS one-way delay to the SDC and the MEAS→CTRL round trip (p50/p99 over turbines'
medians), and the CPU per ViSC sample of every process (each server's ``ovs-vswitchd`` apart). On one
2-core box the servers share the same two cores, so the cluster cannot be faster: this says that it
works and what it costs. Prints one JSON object; ``--json`` writes it too.

    python benchmarks/cluster_runs.py [--cases one_box,one_box_veth,two_servers] [--duration 5] [--json F]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import yaml
from cpu_budget import case_figures  # benchmarks/cpu_budget.py
from scenario_runs import ROOT, finish, run_dict, work_dir  # benchmarks/scenario_runs.py
from time_scale import judge  # benchmarks/time_scale.py

CASES = ("one_box", "one_box_veth", "two_servers")
N_VISC = 50


def case_scenario(case: str, duration: float) -> dict:
    sc = yaml.safe_load((ROOT / "scenarios" / "all_visc_50.yaml").read_text())
    sc.update(name=f"all_visc_50_{case}", duration_s=duration, time_scale="auto")
    if case != "one_box":
        sc.pop("switch_links", None)
        sc.pop("switch_revalidation_ms", None)
    if case == "two_servers":
        sc["cluster"] = {"emulate": 2}
    return sc


def spread(values: list[float]) -> dict | None:
    return {"p50": round(float(np.median(values)), 4), "max": round(float(max(values)), 4)} if values else None


def figures(s: dict) -> dict:
    verdict = judge(s)
    cal = s["time"].get("calibration") or {}
    one_way = [t["one_way_delay_ms"]["meas_to_sdc"]["p50"] for t in s["turbines"].values()
               if (t.get("one_way_delay_ms") or {}).get("meas_to_sdc")]
    samples = [float(t["round_trip_samples"]["median"]) for t in s["turbines"].values()
               if (t.get("round_trip_samples") or {}).get("median") is not None]
    return {"time_scale": s["time"]["time_scale"], "calibration_wall_s": cal.get("wall_s"),
            "calibration_line": cal.get("line"), "holds": verdict["holds"],
            "late_steps": s["late_steps"], "steps": s["steps"], "worst_within_one_sample": verdict["worst_within_one_sample"],
            "meas_to_sdc_one_way_sim_ms_p50_over_turbines": spread(one_way),
            "round_trip_samples_median_over_turbines": spread(samples),
            "wall_s": s["time"]["wall_duration_s"], "setup_wall_s": s["time"]["setup_wall_s"],
            "cpu": case_figures(s, N_VISC)["per_visc_sample_us"] | {
                "total_with_every_ovs": round(sum(v["us_per_step"] for v in s["cpu"].values()) / N_VISC, 2)},
            "placement": (s.get("cluster") or {}).get("placement"),
            "tunnels": len((s.get("cluster") or {}).get("tunnels") or [])}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--duration", type=float, default=5.0)
    ap.add_argument("--json", type=Path)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args()
    work = work_dir(args.out, "sdvisc-cluster-runs-")
    result: dict = {"duration_s": args.duration, "visc": N_VISC, "cases": {}}
    for case in args.cases.split(","):
        if case not in CASES:
            raise SystemExit(f"unknown case {case!r} (cases: {', '.join(CASES)})")
        s = run_dict(case_scenario(case, args.duration), work, "--recalibrate")
        result["cases"][case] = figures(s)
        print(f"{case}: k={s['time']['time_scale']:g} holds={result['cases'][case]['holds']}", file=sys.stderr)
    if args.json:
        args.json.write_text(json.dumps(result, indent=1))
    return finish(result)


if __name__ == "__main__":
    sys.exit(main())
