"""The scaling curve: for N = 1, 4, 16, 50 SDViSCs on the farm, the smallest time scale that holds
and the CPU per ViSC sample of every process at it.

Each N runs the 5 × 10 farm (compact, patch switch links, cpu_split, Open vSwitch revalidation spaced
to 10 s: the settings of ``scenarios/all_visc_50.yaml``), N turbines switched to SDViSC from
t = 0.5 s (10 ms apart, spread over the clusters), ``--duration`` simulated seconds. "Holds" is
:func:`time_scale.judge`'s: < 1 % late plant steps, ≥ 99 % of every turbine's answers within one
sample, no converter trip. k is searched over powers of two upward from the previous N's (the
curve does not fall with N), from ``--start`` for the first; ``--auto`` also runs each N once at
``--time-scale auto`` and reports the k its calibration chose, its cost before t = 0 and whether
it is within one power of two of the smallest that held.

Prints one JSON object and writes ``--png`` (k against N; CPU per ViSC sample per process against
N). Needs root.

    python benchmarks/scaling.py [--turbines 1,4,16,50] [--duration 3] [--start 1] [--max 64] [--auto]
        [--switch-ports system|afxdp|afxdp-nonpmd] [--png scaling.png] [--out DIR]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path

from cpu_budget import case_figures, scenario  # benchmarks/cpu_budget.py
from scenario_runs import finish, run_dict, work_dir  # benchmarks/scenario_runs.py
from time_scale import LATE_MAX, WITHIN_ONE_MIN, judge  # benchmarks/time_scale.py

SETTINGS = {"switch_links": "patch", "cpu_split": True, "switch_revalidation_ms": 10000}  # all_visc_50's


def farm_scenario(n: int, duration: float, k: float | str) -> dict:
    sc = scenario(n, duration, k, "full") | SETTINGS
    sc["name"] = f"scaling_{n}visc_k{k}"
    return sc


def run_at(n: int, k: float | str, args, work: Path) -> dict:
    fresh = ("--recalibrate",) if k == "auto" else ()  # measured, never the calibration cache's k
    return run_dict(farm_scenario(n, args.duration, k), work, "--switch-ports", args.switch_ports, *fresh)


def smallest_k(n: int, start: float, args, work: Path) -> tuple[float | None, dict, dict | None]:
    """(smallest k that held, every verdict, the figures of the run that held)."""
    tried: dict = {}
    k = start
    while k <= args.max:
        s = run_at(n, k, args, work)
        verdict = judge(s)
        verdict.pop("within_one_sample")
        tried[f"{k:g}"] = verdict
        if verdict["holds"]:
            return k, tried, case_figures(s, n)
        k *= 2
    return None, tried, None


def plot(result: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [(int(n.split("_")[0]), c) for n, c in result["cases"].items() if c["smallest_k"] is not None]
    if not rows:
        return
    ns = [n for n, _ in rows]
    fig, (ax_k, ax_cpu) = plt.subplots(1, 2, figsize=(10, 4))
    ax_k.plot(ns, [c["smallest_k"] for _, c in rows], "o-", label="smallest k that holds")
    autos = [(n, c["auto"]["time_scale"]) for n, c in rows if c.get("auto")]
    if autos:
        ax_k.plot(*zip(*autos, strict=True), "s--", label="--time-scale auto chose")
    ax_k.set(xscale="log", yscale="log", xlabel="SDViSCs (N)", ylabel="time scale k", title="Time dilation needed")
    ax_k.set_yticks([1, 2, 4, 8, 16, 32, 64], labels=["1", "2", "4", "8", "16", "32", "64"])
    ax_k.grid(True, which="both", alpha=0.3)
    ax_k.legend()
    names = sorted({p for _, c in rows for p in c["per_visc_sample_us"] if p != "total"})
    bottom = [0.0] * len(rows)
    for name in names:
        values = [c["per_visc_sample_us"].get(name, 0.0) for _, c in rows]
        ax_cpu.bar([str(n) for n in ns], values, bottom=bottom, label=name)
        bottom = [b + v for b, v in zip(bottom, values, strict=True)]
    ax_cpu.axhline(75, color="k", ls=":", label="goal 75 µs")
    ax_cpu.set(xlabel="SDViSCs (N)", ylabel="CPU per ViSC sample, µs", title="CPU per ViSC sample at that k")
    ax_cpu.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--turbines", default="1,4,16,50")
    ap.add_argument("--duration", type=float, default=3.0)
    ap.add_argument("--start", type=float, default=1.0)
    ap.add_argument("--max", type=float, default=64.0)
    ap.add_argument("--auto", action="store_true")
    ap.add_argument("--switch-ports", choices=("system", "afxdp", "afxdp-nonpmd"), default="system")
    ap.add_argument("--png", type=Path)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args()
    work = work_dir(args.out, "sdvisc-scaling-")
    result: dict = {"benchmark": "scaling", "settings": SETTINGS, "switch_ports": args.switch_ports,
                    "duration_s": args.duration, "criteria": {"late_fraction_below": LATE_MAX,
                                                              "within_one_sample_at_least": WITHIN_ONE_MIN},
                    "load_before": os.getloadavg(), "cases": {}}
    started, k = time.time(), args.start
    for n in (int(x) for x in args.turbines.split(",")):
        found, tried, figures = smallest_k(n, k, args, work)
        case = {"smallest_k": found, "tried": tried, **(figures or {})}
        if args.auto:
            s = run_at(n, "auto", args, work)
            cal = s["time"]["calibration"]
            case["auto"] = {"time_scale": cal["time_scale"], "calibration_wall_s": cal["wall_s"],
                            "setup_wall_s": s["time"].get("setup_wall_s"), "run": judge(s) | {"within_one_sample": None},
                            "within_one_power_of_two": found is not None
                            and abs(math.log2(cal["time_scale"] / found)) <= 1}
        result["cases"][f"{n}_visc"] = case
        print(json.dumps({n: {"smallest_k": found, "auto": case.get("auto", {}).get("time_scale")}}), file=sys.stderr)
        k = found or k
    result["wall_s"] = round(time.time() - started, 1)
    if args.png:
        plot(result, args.png)
    return finish(result)


if __name__ == "__main__":
    sys.exit(main())
