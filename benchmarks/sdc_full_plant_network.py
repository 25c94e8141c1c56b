"""``benchmarks/sdc_full_plant.py --network``: the paper's F1 case through the network vs offline.

Runs ``scenarios/fault_4visc_network.yaml`` (SLG fault at the PCC 1.0–1.3 s, four SDViSCs wt1_1,
wt2_1, wt3_1, wt4_1 on the full 500 MW farm, ``remote_apply: v_ref``, the SDC over Open vSwitch)
from a temporary copy recording every step, at ``--time-scale`` (default ``auto``), with
:func:`scenarios.runner.run_scenario` (needs root; run the benchmark under the network lock). Then,
under the run's own conditions (:mod:`plant.cosim_service`: start, fault steps, START parameters,
float32 wire values, read back by :mod:`plant.service.run_record`):

* ``offline_median_rtt``: the offline co-simulation with the run's median MEAS→CTRL round trip
  for every step (normally 1 sample: the answer to the last MEAS drives the next step);
* ``offline_replay``: the offline co-simulation replaying the round trip the run had at each step
  (``timeseries.csv`` ``<wt>.ctrl_lag``);
* ``hd``: the hardware-dependent ViSC (continuous law inside the plant) switched on at the start.

Per comparison, RMS of the difference of |V_pcc|, Q, δ, E over ``WINDOW`` (0.5 s to the end) as %
of the HD trace's range there (worst of the four turbines; :func:`plant.cosim_service.compare_window`).
"""

from __future__ import annotations

import os
import subprocess
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import yaml

from plant.cosim_service import compare_window, run_service_hd, run_service_sdc
from plant.service.run_record import read_run
from scenarios.loader import load_scenario
from scenarios.runner import run_scenario

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scenarios" / "fault_4visc_network.yaml"
TURBINES = ["wt1_1", "wt2_1", "wt3_1", "wt4_1"]
WINDOW_FROM_S = 0.5


def _uptime() -> str:
    return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()


def run_network(time_scale: float | str, out: Path) -> dict:
    """One network run of the F1 scenario into ``out`` (recording every step); its summary."""
    data = yaml.safe_load(SCENARIO.read_text())
    data.setdefault("plant", {})["record_every"] = 1
    out.mkdir(parents=True, exist_ok=True)
    copy = out.parent / f"{out.name}.yaml"
    copy.write_text(yaml.safe_dump(data, sort_keys=False))
    scenario = load_scenario(copy)
    scenario.time_scale = time_scale
    return run_scenario(scenario, out, quiet=True, source=str(copy))


def _peaks(trace: dict) -> list[float]:
    return [round(float(x), 4) for x in np.max(trace["i_wt"], axis=0)]


def _pct(res: dict) -> dict:
    return {name: round(v["rms_over_range_pct"], 4) for name, v in res.items()}


def compare_run(out: Path, summary: dict) -> tuple[dict, dict]:
    """The comparison of one finished run (see the module docstring): (result, traces)."""
    cond, lags, net = read_run(out, TURBINES, step_s=summary["step_s"])
    data = yaml.safe_load(SCENARIO.read_text())
    params = next(e.get("params", {}) for e in data["timeline"] if e.get("do") == "visc_on")
    sdc = data.get("sdc", {})
    cond = replace(cond, params=dict(params), method=sdc.get("method", cond.method), dtype=sdc.get("dtype", cond.dtype))
    medians = {wt: int(summary["turbines"][wt]["round_trip_samples"]["median"].lstrip(">")) for wt in TURBINES}
    median = max(medians.values())
    runs = {"network": net, "offline_median_rtt": run_service_sdc(cond, lag=median),
            "offline_replay": run_service_sdc(cond, lag=lags), "hd": run_service_hd(cond)}
    hd = runs["hd"]
    window = (WINDOW_FROM_S, cond.n_steps * cond.step_s)
    pairs = {"network_vs_offline_median_rtt": ("network", "offline_median_rtt"),
             "network_vs_offline_replay": ("network", "offline_replay"),
             "network_vs_hd": ("network", "hd"), "offline_median_rtt_vs_hd": ("offline_median_rtt", "hd")}
    late = {wt: [round((k + 1) * cond.step_s, 5) for k in np.nonzero(lags[:, j] > 1)[0][:20]] for j, wt in enumerate(TURBINES)}
    result = {
        "out": str(out),
        "time_scale": summary["time"]["time_scale"],
        "wall_duration_s": summary["time"]["wall_duration_s"],
        "late_steps": summary["late_steps"], "steps": summary["steps"],
        "round_trip_samples": {wt: summary["turbines"][wt]["round_trip_samples"] for wt in TURBINES},
        "offline_round_trip_samples": median,
        "steps_with_older_control_t_s": late,
        "conditions": {"start_steps": cond.start_steps, "first_used_seq": cond.first_used_seq,
                       "fault_steps": cond.fault_steps, "params": cond.params},
        "converter_trips": {"network": summary.get("converter_trips", {}),
                            "offline_median_rtt": runs["offline_median_rtt"]["trips"].tolist(),
                            "offline_replay": runs["offline_replay"]["trips"].tolist(), "hd": hd["trips"].tolist()},
        "peak_current_pu": {name: _peaks(r) for name, r in runs.items()},
        "window_s": [WINDOW_FROM_S, round(window[1], 4)],
        "hd_range": {name: round(v["reference_range"], 4) for name, v in compare_window(hd, hd, hd, *window).items()},
        "rms_over_hd_range_pct": {key: _pct(compare_window(runs[a], runs[b], hd, *window)) for key, (a, b) in pairs.items()},
    }
    return result, runs


def main_network(time_scale: float | str, n_runs: int, out_root: Path | None, figure: str | None) -> dict:
    if os.geteuid() != 0:
        raise SystemExit("--network needs root (Mininet); run it under flock /tmp/sdvisc-net.lock")
    root = out_root or Path(tempfile.mkdtemp(prefix="sdvisc-f1-network-"))
    result: dict = {"benchmark": "sdc_full_plant --network", "scenario": str(SCENARIO.relative_to(ROOT)),
                    "cpus": os.cpu_count(), "uptime_before": _uptime(), "runs": []}
    started = time.time()
    runs = None
    for n in range(n_runs):
        out = root / f"run{n + 1}"
        summary = run_network(time_scale, out)
        one, runs = compare_run(out, summary)
        result["runs"].append(one)
    result["uptime_after"] = _uptime()
    result["wall_s"] = round(time.time() - started, 1)
    result["runs_with_converter_trips"] = sum(1 for r in result["runs"] if r["converter_trips"]["network"])
    if figure and runs is not None:
        plot(runs, figure)
        result["figure"] = figure
    return result


def plot(runs: dict, path: str) -> None:
    import matplotlib  # noqa: PLC0415

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    fig, axes = plt.subplots(4, 1, figsize=(8, 9), sharex=True)
    labels = {"v_pcc": "|V_pcc| [p.u.]", "q": "Q of ViSC wt1_1 [p.u.]", "delta": "δ of wt1_1 [rad]", "e_mag": "E of wt1_1 [p.u.]"}
    styles = (("hd", "k", 1.6, "HD ViSC (continuous, in the plant)"),
              ("network", "C3", 1.0, "SDViSC through the network (Open vSwitch, virtual time)"),
              ("offline_median_rtt", "C0--", 1.0, "SDViSC offline, median round trip"))
    for ax, name in zip(axes, labels):
        for key, style, lw, label in styles:
            ax.plot(runs[key]["t"], runs[key][name][:, 0], style, lw=lw, label=label)
        ax.set_ylabel(labels[name])
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("t [s] (ViSC on at 0.2 s, single-phase-to-ground fault at the PCC 1.0–1.3 s)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
