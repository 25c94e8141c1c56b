"""The EMT backend's cost (plant/emt/, DPsim 1.4.0): process CPU seconds per simulated second of the
comparison arrangement at the 51.5 µs step (Ts/13), one simulated second after the operating point, for

* ``none``: grid + the farm's injection only;
* ``sc``: + the 40 MVA SC (its rotor and AVR in Python at every step);
* ``visc``: + the 40 MVA SDViSC with the ViSC law at every step (the HD ViSC, the report's EMT rows; the
  law compiled by sdc_unit.law_jit, compiled before the timed runs);
* ``visc_ts``: the same law sampled every Ts = 0.67 ms (stable here only with the converter's active
  damping raised to k_ad 0.5, plant/emt/devices.py);
* ``*_solver_only``: the same circuits stepped by ``sim.next()`` alone, no Python between the steps
  (DPsim's own cost: the rest is the Python exchange);
* ``farm_4visc_sc``: F8's farm arrangement (plant/emt/farm.py) with the four SDViSCs (the ViSC law at every
  step, activated at the start) and the SC (rotor and AVR at every step), the farm with its WPP, and its
  ``_solver_only`` twin. Goal (issue 40): >= 2x faster than real time offline, i.e. <= 0.5 CPU-s per
  simulated second;
* ``farm_4visc_sc_ts``: the same with the exchange every Ts (plant/emt/farm_run.py ``exchange="ts"``: the law
  and the SC's rotor every Ts, the converters' active damping inside the circuit), recorded every Ts;
  ``_gfl``: the rest of the farm as the aggregated grid-following converter (plant/emt/gfl_farm.py, as
  EMTW runs it); ``_record_every_step``: the terminals and currents read every step as well (what F8's
  instantaneous peaks need).

Usage: nice -n 10 .venv/bin/python benchmarks/emt_step_cost.py [--out benchmarks/measured/emt-step-cost-DATE.json]
The load average at the start and the end is in the JSON: the 2 cores are shared.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from plant.emt import arrangement, netlist  # noqa: E402
from plant.emt.dpsim_env import emt_simulation  # noqa: E402
from plant.emt.farm import EmtFarm  # noqa: E402
from plant.emt.model import EmtComparison  # noqa: E402
from sdvisc.jsonlines import write_json_atomic

SIM_S = 1.0


def with_exchange(device: str, law_every: int = 1, k_ad: float | None = None) -> dict:
    m = EmtComparison(device, law_every=law_every)
    if k_ad is not None:
        m.visc.k_ad = k_ad
    r = m.run(SIM_S)
    return {"cpu_s_per_sim_s": r["cpu_s"] / SIM_S, "wall_s_per_sim_s": r["wall_s"] / SIM_S,
            "us_per_step": r["cpu_s"] / len(r["t"]) * 1e6, "steps": len(r["t"]), "step_s": r["h"]}


def _solver_cost(name: str, system, h: float) -> dict:
    """DPsim's own EMT step on ``system`` at ``h`` for SIM_S, nothing exchanged between steps."""
    sim = emt_simulation(name, system, h, SIM_S + 1.0)
    n = int(round(SIM_S / h))
    sim.start()
    c0 = time.process_time()
    for _ in range(n):
        sim.next()
    cpu = time.process_time() - c0
    sim.stop()
    return {"cpu_s_per_sim_s": cpu / SIM_S, "us_per_step": cpu / n * 1e6, "steps": n}


def solver_only(device: str) -> dict:
    m = EmtComparison(device)
    return _solver_cost(f"bench_{device}", arrangement.build(m.op).sys, m.h)


def farm_with_exchange(**kw) -> dict:
    m = EmtFarm(4, (0.03, 0.05, 0.07, 0.10), with_sc=True, **kw)
    r = m.run(SIM_S, events=[(0.0, EmtFarm.activate)])
    return {"cpu_s_per_sim_s": r["cpu_s"] / SIM_S, "wall_s_per_sim_s": r["wall_s"] / SIM_S,
            "us_per_step": r["cpu_s"] / len(r["t"]) * 1e6, "steps": len(r["t"]), "step_s": r["h"],
            "faster_than_real_time": SIM_S / r["cpu_s"]}


def farm_solver_only() -> dict:
    m = EmtFarm(4, (0.03, 0.05, 0.07, 0.10), with_sc=True)
    return _solver_cost("bench_farm", netlist.build(m.circ.net, m.circ.v0).sys, m.h)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="")
    args = ap.parse_args()
    load_before = os.getloadavg()
    EmtComparison("visc").run(0.002)  # compiles the law (sdc_unit.law_jit) outside the timed runs
    res = {"none": with_exchange("none"), "sc": with_exchange("sc"), "visc": with_exchange("visc"),
           "visc_ts": with_exchange("visc", law_every=13, k_ad=0.5)}
    for dev in ("none", "sc", "visc"):
        res[f"{dev}_solver_only"] = solver_only(dev)
    res["farm_4visc_sc"] = farm_with_exchange()
    res["farm_4visc_sc_ts"] = farm_with_exchange(exchange="ts")
    res["farm_4visc_sc_ts_gfl"] = farm_with_exchange(exchange="ts", farm_model="gfl")
    res["farm_4visc_sc_ts_record_every_step"] = farm_with_exchange(exchange="ts", record_every_step=True)
    res["farm_4visc_sc_solver_only"] = farm_solver_only()
    out = {"what": "EMT backend CPU per simulated second (benchmarks/emt_step_cost.py)",
           "date": datetime.date.today().isoformat(), "host": platform.node(), "cpus": os.cpu_count(),
           "note": "nice 10, 2 cores shared with other jobs; process CPU of this process only", "results": res,
           "load_average_before": load_before, "load_average_after": os.getloadavg()}
    print(json.dumps(out, indent=1))
    if args.out:
        write_json_atomic(args.out, out)


if __name__ == "__main__":
    main()
