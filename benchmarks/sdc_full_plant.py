"""The paper's validation case on the full plant: Tustin SDViSC at 0.67 ms vs the HD ViSC.

Usage: .venv/bin/python benchmarks/sdc_full_plant.py [--figure PATH]   (~1 min)
Prints one JSON object: per variant (delay in samples, dtype, method) the RMS deviation from the
hardware-dependent ViSC and RMS / range of the HD trace [%] of |V_pcc|, Q, delta and E (worst of
the four ViSC turbines), and writes a figure (default docs/figures/sdc_full_plant_fault.png).
See plant/cosim.py for the set-up.

    flock /tmp/sdvisc-net.lock .venv/bin/python benchmarks/sdc_full_plant.py --network [--time-scale K|auto] [--runs N]

runs the same case through the network (scenarios/fault_4visc_network.yaml, needs root) and compares
it with the offline co-simulation under the run's own conditions and with the HD ViSC
(benchmarks/sdc_full_plant_network.py; figure default docs/figures/sdc_full_plant_network.png).
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from plant.cosim import FaultCase, compare, run_hd, run_sdc  # noqa: E402

VARIANTS = [("tustin", "float64", 0), ("tustin", "float64", 1), ("tustin", "float64", 3),
            ("tustin", "float32", 0), ("euler", "float64", 0)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--figure", default=None, help="figure path ('' for none)")
    ap.add_argument("--network", action="store_true", help="run the case through the network (root) and compare")
    ap.add_argument("--time-scale", default="auto", metavar="K|auto", help="with --network: virtual time scale")
    ap.add_argument("--runs", type=int, default=1, help="with --network: how many network runs")
    ap.add_argument("--out", type=Path, default=None, help="with --network: directory for the runs' output")
    args = ap.parse_args()
    docs = Path(__file__).resolve().parents[1] / "docs/figures"
    if args.network:
        from sdc_full_plant_network import main_network  # noqa: PLC0415 - needs scenarios (root) only here

        scale = args.time_scale if args.time_scale == "auto" else float(args.time_scale)
        figure = str(docs / "sdc_full_plant_network.png") if args.figure is None else args.figure or None
        print(json.dumps(main_network(scale, args.runs, args.out, figure), indent=1))
        return
    args.figure = str(docs / "sdc_full_plant_fault.png") if args.figure is None else args.figure
    case = FaultCase()
    hd = run_hd(case)
    runs = {f"{m}_{d}_delay{k}": run_sdc(case, method=m, dtype=np.dtype(d), delay_samples=k) for m, d, k in VARIANTS}
    result = {"benchmark": "sdc_full_plant", "machine": platform.platform(),
              "case": {k: getattr(case, k) for k in case.__dataclass_fields__},
              "results": {name: compare(r, hd) for name, r in runs.items()}}
    print(json.dumps(result, indent=1))
    import matplotlib  # noqa: PLC0415

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    fig, axes = plt.subplots(4, 1, figsize=(8, 9), sharex=True)
    labels = {"v_pcc": "|V_pcc| [p.u.]", "q": "Q of ViSC wt1_1 [p.u.]", "delta": "δ of wt1_1 [rad]", "e_mag": "E of wt1_1 [p.u.]"}
    for ax, name in zip(axes, labels):
        ax.plot(hd["t"], hd[name][:, 0], "k", lw=1.6, label="HD ViSC (continuous, in the plant)")
        for key, style in (("tustin_float64_delay0", "C0--"), ("tustin_float64_delay1", "C1:")):
            ax.plot(runs[key]["t"], runs[key][name][:, 0], style, lw=1.0, label=f"Tustin 0.67 ms, {key[-6:]}")
        ax.set_ylabel(labels[name])
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("t [s] (single-phase-to-ground fault at the PCC 1.0–1.3 s)")
    fig.tight_layout()
    fig.savefig(args.figure, dpi=110)


if __name__ == "__main__":
    main()
