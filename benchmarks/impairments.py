"""Link impairment element: delay precision, loss accuracy and CPU on one SDViSC's traffic (root).

Runs the smoke scenario (wt1_1 as SDViSC: 1 MEAS + 1 CTRL every Ts = 0.67 ms, i.e. 2 × 1500
frames/s, all across s1–s3) with an impairment element on s1–s3, once per configured delay (no
jitter, ``--loss`` loss, a seed of its own), plus once without the element (the baseline of the
end-to-end delays); delay 0 shows what the element itself adds.
Prints one JSON object; per delay:

* ``error_ms``: the element's added delay (departure − kernel receive stamp) minus the configured
  delay, p50/p95/max over every frame (goal: p95 ≤ 0.2 ms at time scale 1, delays 1–20 ms);
* ``end_to_end_added_ms``: the turbine's MEAS→SDC and CTRL→turbine one-way p50 minus the
  baseline's (what the applications saw; includes the element's own forwarding);
* ``loss``: frames dropped by loss / offered, the 99 % binomial interval of the configured rate
  over that many frames and whether the measured rate is inside (≥ 20,000 frames with the defaults);
* ``cpu``: the element's CPU seconds (from /proc, t = 0 to the end, idle second before the
  request included), µs per frame and % of a core per 1,000 frames/s (goal ≤ 5 %).

The SDN app's DR hold is raised to 0.5 s so that the 40 ms round trip of the 20 ms case does not
reroute the turbine around the element before its first control packet arrives. The machine is
shared: ``machine.load`` before and after says how busy it was.

    .venv/bin/python benchmarks/impairments.py [--delays 0,1,5,20] [--loss 0.01] [--duration 8] [--time-scale 1]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import tempfile
from pathlib import Path

import yaml
from scenario_runs import ROOT, machine, run_dict  # benchmarks/scenario_runs.py

from impairment.queue import binomial_interval


def scenario(name: str, duration_s: float, links: list[dict], time_scale: float) -> dict:
    sc = yaml.safe_load((ROOT / "scenarios" / "smoke.yaml").read_text())
    sc.update(name=name, duration_s=duration_s, time_scale=time_scale, links=links,
              sdn={"dr_hold_s": 0.5, "ak_timeout_s": 0.2})
    return sc


def p50s(summary: dict) -> tuple[float, float]:
    delays = summary["turbines"]["wt1_1"]["one_way_delay_ms"]
    return delays["meas_to_sdc"]["p50"], delays["ctrl_to_turbine"]["p50"]


def measure(summary: dict, baseline: dict, delay_ms: float, loss: float) -> dict:
    (link,) = summary["impairments"]["links"]
    (phase,) = link["phases"]
    offered, lost = phase["offered"], phase["dropped_loss"]
    low, high = binomial_interval(offered, loss)
    rate = lost / offered if offered else None
    cpu_s = summary["cpu"].get(f"{link['element']}.impair", {}).get("cpu_s")
    wall = summary["time"]["wall_duration_s"]
    meas, ctrl = p50s(summary)
    meas0, ctrl0 = p50s(baseline)
    return {
        "delay_ms": delay_ms,
        "error_ms": phase["added_delay_error_ms"],
        "late_ms": phase["late_ms"],
        "end_to_end_added_ms": {"meas_to_sdc_p50": round(meas - meas0, 3), "ctrl_to_turbine_p50": round(ctrl - ctrl0, 3)},
        "loss": {"configured": loss, "offered": offered, "dropped": lost, "rate": round(rate, 5) if rate is not None else None,
                 "interval_99": [round(low, 5), round(high, 5)], "within": rate is not None and low <= rate <= high},
        "frames_per_s": round(offered / wall, 1) if wall else None,
        "cpu": {"cpu_s": cpu_s, "us_per_frame": round(cpu_s / offered * 1e6, 2) if cpu_s and offered else None,
                "pct_core_per_1000_fps": round(cpu_s / wall * 100 / (offered / wall / 1000), 2) if cpu_s and wall and offered
                else None},
        "scheduling": link.get("scheduling"),
        "recoveries": len(summary["recoveries"]),
        "late_steps": summary["late_steps"],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--delays", default="0,1,5,20", help="configured one-way delays, ms (0: the element's own cost)")
    parser.add_argument("--loss", type=float, default=0.01)
    parser.add_argument("--duration", type=float, default=8.0, help="simulated s per run (ViSC from 1 s)")
    parser.add_argument("--time-scale", type=float, default=1.0)
    parser.add_argument("--work", default=None, help="keep the runs here (default: a temporary directory)")
    args = parser.parse_args()
    load_before = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    work = Path(args.work or tempfile.mkdtemp(prefix="sdvisc-impair-"))
    work.mkdir(parents=True, exist_ok=True)
    extra = ("--time-scale", f"{args.time_scale:g}")
    baseline = run_dict(scenario("impair_bench_baseline", args.duration, [], args.time_scale), work, *extra)
    results = []
    for index, delay in enumerate(float(d) for d in args.delays.split(",")):
        link = {"a": "s1", "b": "s3", "delay_ms": delay, "loss": args.loss, "seed": 1 + index}  # independent draws
        name = f"impair_bench_{delay:g}ms".replace(".", "_")
        summary = run_dict(scenario(name, args.duration, [link], args.time_scale), work, *extra)
        results.append(measure(summary, baseline, delay, args.loss))
    print(json.dumps({
        "benchmark": "impairments",
        "time_scale": args.time_scale,
        "duration_s": args.duration,
        "goals": {"error_p95_ms": 0.2, "pct_core_per_1000_fps": 5.0, "loss_within_99_interval": True},
        "baseline_one_way_p50_ms": dict(zip(("meas_to_sdc", "ctrl_to_turbine"), p50s(baseline))),
        "runs": results,
        "machine": {**machine(), "uptime_before": load_before,
                    "uptime_after": subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()},
        "work": str(work),
    }, indent=1))


if __name__ == "__main__":
    main()
