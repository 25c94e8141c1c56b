"""The EMT plant service's speed (``plant.model: emt``, plant/emt/service_backend.py): process CPU seconds
per simulated second offline, and the time scale ``auto`` picked for runs through the network.

Offline (this process, nothing paced): F6's timeline (SLG fault 1.0-1.2 s) for ``SIM_S`` simulated
seconds on the plant service's core (plant.service.core.PlantCore) over the EMT backend,

* ``backend_own_law``: the backend alone, its SDViSC on its own law at every circuit step (no stream);
* ``service_sdc_loop``: the unit streaming, every MEAS answered by the SDC's Tustin law in-process through
  the GTNET-SKT encoding (plant/emt/service_loop.py): the plant service's work and the SDC's, one process;
* ``sdc_law_only``: the SDC's share of it (the same number of law steps on recorded MEAS), subtracted to
  give ``plant_side`` (the plant service's own cost, what its process spends in a network run).

Real time is 1.0 CPU-s per simulated second; issue 40's goal "≥ 2× faster than real time" is ≤ 0.5.

Network (``--runs DIR ...``): from finished runs' summary.json (``sdvisc run … --plant emt --time-scale
auto``), the time scale picked, the calibration's candidates and why each failed, late steps, packet
counts, and the plant process's CPU per simulated second.

Usage: nice -n 10 .venv/bin/python benchmarks/emt_service_speed.py [--runs DIR ...] [--out FILE]
(default FILE benchmarks/measured/emt-service-speed-DATE.json). The load average at the start and the
end is in the JSON: the 2 cores are shared.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from plant.backend import close_backend  # noqa: E402
from plant.emt.service_loop import emt_core, sdc_loop, start_stream  # noqa: E402
from sdc_unit.discrete import DiscreteVisc  # noqa: E402
from sdvisc.jsonlines import write_json_atomic  # noqa: E402

SIM_S = 2.0
TS = 0.67e-3
FAULT_ON_S, FAULT_OFF_S = 1.0, 1.2  # scenarios/paper/f6_slg_fault_current.yaml


def _fault_steps() -> dict:
    return {int(round(FAULT_ON_S / TS)): True, int(round(FAULT_OFF_S / TS)): False}


def backend_own_law() -> dict:
    core = emt_core(duration_s=SIM_S)
    try:
        core.step(0.0)  # a first step outside the timing, as the service's warm start
        faults = _fault_steps()
        cpu0, wall0 = time.process_time(), time.perf_counter()
        for k in range(int(round(SIM_S / TS))):
            if k in faults:
                core.apply_event({"type": "fault", "on": faults[k]})
            core.step(core.k * TS)
        return _rate(time.process_time() - cpu0, time.perf_counter() - wall0)
    finally:
        close_backend(core.model)


def service_sdc_loop() -> tuple[dict, np.ndarray]:
    core = emt_core(duration_s=SIM_S)
    try:
        start_stream(core)
        cpu0, wall0 = time.process_time(), time.perf_counter()
        v = sdc_loop(core, SIM_S, fault=_fault_steps())
        out = _rate(time.process_time() - cpu0, time.perf_counter() - wall0)
        ep = core.streaming[0]
        out.update(meas_tx=ep.counts["meas_tx"], ctrl_rx=ep.counts["ctrl_rx"], fallbacks=int(core.model.fallbacks.sum()),
                   v_terminal_before_fault=round(float(v[int(FAULT_ON_S / TS) - 1]), 5),
                   v_terminal_min_in_fault=round(float(v[int(FAULT_ON_S / TS):int(FAULT_OFF_S / TS)].min()), 5),
                   v_terminal_end=round(float(v[-1]), 5))
        return out, v
    finally:
        close_backend(core.model)


def sdc_law_only(n: int) -> dict:
    """``n`` steps of the SDC's Tustin law on a constant MEAS (its cost does not depend on the values)."""
    from types import SimpleNamespace

    from plant.emt.operating_point import from_phasor_plant

    op, _ = from_phasor_plant("visc")
    i = op.i_device / op.k_device
    s = op.v_terminal * np.conj(i)
    meas = SimpleNamespace(**{k: np.array([x]) for k, x in dict(
        v_d=op.v_terminal.real, v_q=op.v_terminal.imag, i_d=i.real, i_q=i.imag, p=s.real, q=s.imag, v_dc=1.0,
        omega_meas=1.0).items()})
    law = DiscreteVisc(1, op.visc_params, ts=TS, method="tustin")
    law.initialise(np.arange(1), meas)
    law.step(meas)
    cpu0, wall0 = time.process_time(), time.perf_counter()
    for _ in range(n):
        law.step(meas)
    return _rate(time.process_time() - cpu0, time.perf_counter() - wall0)


def _rate(cpu_s: float, wall_s: float) -> dict:
    return {"cpu_s": round(cpu_s, 3), "wall_s": round(wall_s, 3),
            "cpu_s_per_simulated_s": round(cpu_s / SIM_S, 4), "faster_than_real_time_x": round(SIM_S / cpu_s, 2)}


def network_runs(dirs: list[str]) -> list[dict]:
    rows = []
    for d in dirs:
        s = json.loads((Path(d) / "summary.json").read_text())
        plant = json.loads((Path(d) / "plant_stats.json").read_text())
        cal = s["time"].get("calibration") or {}
        rows.append({"dir": d, "scenario": s["scenario"], "completed": s["completed"],
                     "time_scale": s["time"]["time_scale"],
                     "candidates": [{k: c.get(k) for k in ("k", "ok", "limit_used", "within_one_sample_worst",
                                                            "why_not")} for c in cal.get("candidates", [])],
                     "steps": s["steps"], "late_steps": s["late_steps"], "fallbacks": s.get("fallbacks"),
                     "packets": {wt: t["packets"] for wt, t in s["turbines"].items()},
                     "plant_cpu_s_per_simulated_s": round(plant["cpu_s"] / s["duration_s"], 4),
                     "advice": s.get("advice")})
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", nargs="*", default=[], help="finished --plant emt run directories")
    ap.add_argument("--out", default=f"benchmarks/measured/emt-service-speed-{datetime.date.today()}.json")
    args = ap.parse_args()
    load_before = os.getloadavg()
    own = backend_own_law()
    loop, _ = service_sdc_loop()
    law = sdc_law_only(loop["meas_tx"])
    plant_side = round(loop["cpu_s_per_simulated_s"] - law["cpu_s_per_simulated_s"], 4)
    out = {"benchmark": "emt_service_speed", "date": datetime.datetime.now(datetime.timezone.utc).isoformat(),
           "machine": {"cpus": os.cpu_count(), "python": platform.python_version()}, "simulated_s": SIM_S,
           "offline": {"backend_own_law": own, "service_sdc_loop": loop, "sdc_law_only": law,
                       "plant_side_cpu_s_per_simulated_s": plant_side},
           "network": network_runs(args.runs),
           "load_average_before": load_before, "load_average_after": os.getloadavg()}
    write_json_atomic(args.out, out)
    print(json.dumps(out["offline"], indent=1))
    for r in out["network"]:
        print(r["dir"], "k =", r["time_scale"], "late", r["late_steps"], r["packets"])
    print(f"load average {load_before} -> {out['load_average_after']}; written {args.out}")


if __name__ == "__main__":
    main()
