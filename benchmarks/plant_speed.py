"""Offline speed of the plant: simulated seconds per wall-clock second (prints one JSON object).

Usage: python benchmarks/plant_speed.py [sim_seconds] [--realtime]
The wall clock is used here only to measure the benchmark, never inside the model.

realtime_factor_*: sim_seconds / wall seconds of one uninterrupted run of step() + measurements();
``*_4remote_applied`` is the plant service's loop with four remote turbines (``_rate_applied``):
each step new references are applied (``apply_remote``, as the service applies each step's CTRL),
then step() and measurements(), on the plant the service builds (remote_apply "i_ref", the
PlantConfig default; until 2026-12-01 this mode ran with "v_ref" and read the references from the
plant's private evaluation cache, work the service does not do); ``cpu_us_per_step_*`` is the
process CPU per step of that run (less disturbed by other load than the wall time).
``recorder_50wt_4remote``: the CPU of one call of the plant service's recorder on that plant,
``outputs()`` (every quantity) against ``recorded()`` (what ``timeseries.csv`` holds, the
recorder's call since 2026-12-02), per call and per step at the default ``record_every``.
``*_4hd_visc_battery`` (F5: batteries on the four SDViSCs' DC links) and ``*_scr2_limiting`` (a grid of
SCR 2 where the grid-following turbines' current limiters act, as in F7/F9's searches) run the
compiled step too: it covers the batteries and every limiter (plant/turbine_kernels.py).
compute_over_step_fraction_4visc: fraction of the individual step() + measurements() calls of the
four-hd_visc case whose own compute time exceeded step_s. That is a lower bound of the paced
service's late fraction (it leaves out sleeping/wake-up jitter, socket I/O and catch-up).
late_fraction_4visc is measured by the real-time service with ``--realtime`` (root: runs
scenarios/plant_rt_4visc.yaml on Mininet + Open vSwitch, ~25 s); without it, it is null.
``--realtime`` also prints min_time_scale_4visc and min_time_scale_50visc: the smallest k (1, 2, 4, …
64) at which plant_rt_4visc / all_visc_50 hold — < 1 % late steps, ≥ 99 % of every turbine's answers
within one sample, no converter trip (benchmarks/time_scale.py's judge; ~5–15 min).
"""

from __future__ import annotations

import json
import os
import platform
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
# one BLAS thread, as the runner gives the services (scenarios/processes.py): an idle OpenBLAS pool
# spinning on the second core would be counted in the process CPU
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from dataclasses import replace  # noqa: E402

import numpy as np  # noqa: E402

from plant.cases import visc_plant  # noqa: E402
from plant.params import PlantParams  # noqa: E402
from plant.sim import Plant  # noqa: E402
from plant.turbine import REMOTE  # noqa: E402
from sdvisc.config import PlantConfig  # noqa: E402

WEAK_SCR = 2.0  # a grid weak enough for the 50 grid-following turbines' current limiters to act


def _rate(p: Plant, t_sim: float) -> float:
    n = int(round(t_sim / p.step_s))
    t0 = time.perf_counter()
    for _ in range(n):
        p.step()
        p.measurements()
    return n * p.step_s / (time.perf_counter() - t0)


def _service_plant(remote_idx: np.ndarray) -> Plant:
    """50 turbines as the plant service builds its full model (plant/service/model.py) with the
    PlantConfig defaults a scenario does not override: remote turbines track the received current
    reference (``remote_apply``) and fall back after ``remote_loss_fallback_s``; ``remote_idx`` remote."""
    fields = PlantConfig.model_fields
    base = PlantParams()
    turbine = replace(base.turbine, remote_apply=fields["remote_apply"].default,
                      remote_loss_fallback_s=fields["remote_loss_fallback_s"].default)
    p = Plant(replace(base, turbine=turbine), n_turbines=50)
    p.set_mode(remote_idx, "remote")
    return p


def _rate_applied(p: Plant, idx: np.ndarray, t_sim: float) -> tuple[float, float]:
    """As _rate, with the remote turbines ``idx`` getting new references every step as the plant
    service's core (``PlantCore.step`` in plant/service/core.py) does with each step's CTRL packets:
    ``apply_remote`` with an ``intp`` index array and ``float64`` references, ``step()``, then
    ``measurements()`` for the MEAS; the references answer the last measurements (current
    reference the measured current, voltage reference the measured terminal voltage, unused with
    remote_apply "i_ref"), so the four stay in remote mode (checked at the end). Not included, as in every mode: the service's packet
    decoding and encoding and its recorder's ``outputs()`` every ``record_every`` steps. Returns
    (realtime factor, process CPU µs per step)."""
    n = int(round(t_sim / p.step_s))
    index = idx.astype(np.intp)
    m = p.measurements()
    cpu0, t0 = time.process_time(), time.perf_counter()
    for _ in range(n):
        p.apply_remote(index, m["v_d"][idx], m["v_q"][idx], m["i_d"][idx], m["i_q"][idx])
        p.step()
        m = p.measurements()
    wall, cpu = time.perf_counter() - t0, time.process_time() - cpu0
    if (p.tb.mode[idx] != REMOTE).any():
        raise RuntimeError("a remote turbine tripped or fell back: the run did not measure the remote mode")
    return n * p.step_s / wall, cpu / n * 1e6


def _record_cost_us(p: Plant, idx: np.ndarray, calls: int = 1500) -> dict:
    """Process CPU µs of one recorder call on the service's plant (four remote turbines), made as the
    service makes it: after ``apply_remote``, ``step()`` and ``measurements()``, the evaluation of
    the new state already done. ``outputs()`` (what the recorder called until 2026-12-02: every
    quantity, with the full node-voltage solve and the fault sequences) against ``recorded()``
    (only what ``timeseries.csv`` holds), alternated call by call."""
    index = idx.astype(np.intp)
    spent = {"outputs": 0.0, "recorded": 0.0}
    m = p.measurements()
    for k in range(2 * calls):
        p.apply_remote(index, m["v_d"][idx], m["v_q"][idx], m["i_d"][idx], m["i_q"][idx])
        p.step()
        m = p.measurements()
        name = "outputs" if k % 2 else "recorded"
        call = getattr(p, name)
        t0 = time.process_time()
        call()
        spent[name] += time.process_time() - t0
    every = PlantConfig.model_fields["record_every"].default
    out = {f"{name}_us_per_call": round(cpu / calls * 1e6, 1) for name, cpu in spent.items()}
    out.update({f"{name}_us_per_step_at_record_every_{every}": round(cpu / calls * 1e6 / every, 2)
                for name, cpu in spent.items()})
    return out


def _over_step_fraction(p: Plant, t_sim: float) -> float:
    n = int(round(t_sim / p.step_s))
    dt = np.empty(n)
    clock = time.perf_counter
    for k in range(n):
        t0 = clock()
        p.step()
        p.measurements()
        dt[k] = clock() - t0
    return float(np.mean(dt > p.step_s))


def _realtime_late_fraction() -> float | None:
    """Run scenarios/plant_rt_4visc.yaml (full farm model paced in real time, four turbines run by
    the SDC over Mininet + Open vSwitch for 10 s; root) and return late steps / steps."""
    import tempfile  # noqa: PLC0415

    from scenarios.loader import load_scenario  # noqa: PLC0415
    from scenarios.runner import run_scenario  # noqa: PLC0415

    root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
    with tempfile.TemporaryDirectory() as out:
        summary = run_scenario(load_scenario(os.path.join(root, "scenarios", "plant_rt_4visc.yaml")), out, quiet=True)
    return round(summary["late_steps"] / summary["steps"], 4) if summary.get("steps") else None


def _min_time_scales() -> dict:
    import tempfile  # noqa: PLC0415
    from pathlib import Path  # noqa: PLC0415

    from time_scale import smallest_time_scale  # noqa: PLC0415 - benchmarks/time_scale.py, beside this file

    out: dict = {}
    with tempfile.TemporaryDirectory() as work:
        for key, name, start in (("4visc", "plant_rt_4visc", 1.0), ("50visc", "all_visc_50", 1.0)):
            found, tried = smallest_time_scale(name, Path(work), start=start)
            out[f"min_time_scale_{key}"] = found
            out[f"time_scale_tried_{key}"] = {k: {m: v[m] for m in ("late_fraction", "worst_within_one_sample",
                                                                       "converter_trips", "holds")}
                                              for k, v in tried.items()}
    return out


def main() -> None:
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    realtime = "--realtime" in sys.argv[1:]
    t_sim = float(args[0]) if args else 3.0
    out = {"step_s": 0.67e-3, "sim_seconds": t_sim}
    out["realtime_factor_50wt"] = round(_rate(Plant(n_turbines=50), t_sim), 3)
    try:
        p = Plant(n_turbines=50)
        idx = np.arange(20, 24)
        p.set_power_ref(idx, p=0.0)
        p.reinitialise()
        p.set_mode(idx, "hd_visc")
        out["realtime_factor_50wt_4hd_visc"] = round(_rate(p, t_sim), 3)
        out["compute_over_step_fraction_4visc"] = round(_over_step_fraction(p, t_sim), 4)
        out["late_fraction_4visc"] = _realtime_late_fraction() if realtime else None
        if realtime:
            out.update(_min_time_scales())
    except RuntimeError as exc:  # sdc_unit.law not available
        out["realtime_factor_50wt_4hd_visc"] = None
        out["note"] = str(exc)
    p = Plant(n_turbines=50)
    p.set_mode(np.arange(20, 24), "remote")
    out["realtime_factor_50wt_4remote"] = round(_rate(p, t_sim), 3)
    factor, cpu_us = _rate_applied(_service_plant(np.arange(20, 24)), np.arange(20, 24), t_sim)
    out["realtime_factor_50wt_4remote_applied"] = round(factor, 3)
    out["cpu_us_per_step_50wt_4remote_applied"] = round(cpu_us, 1)
    out["recorder_50wt_4remote"] = _record_cost_us(_service_plant(np.arange(20, 24)), np.arange(20, 24))
    # the report's other plants: F5's batteries on the four SDViSCs' DC links, and a weak grid (F7/F9's
    # searches) where the grid-following turbines' current limiters act
    out["realtime_factor_50wt_4hd_visc_battery"] = round(_rate(visc_plant(4, battery=True), t_sim), 3)
    p = Plant(n_turbines=50)
    p.set_scr(WEAK_SCR)
    out["realtime_factor_50wt_scr2_limiting"] = round(_rate(p, t_sim), 3)
    out["machine"] = {"processor": platform.processor() or platform.machine(), "cpu_count": os.cpu_count(),
                      "python": platform.python_version(), "numpy": np.__version__}
    print(json.dumps(out))


if __name__ == "__main__":
    main()
