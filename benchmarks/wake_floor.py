"""The floor under the chain's CPU per sample at one ViSC turbine: what the plant and the SDC cost
when each wakes once per sample, with no network at all.

Prints ONE JSON object (medians of ``--repeat``). In one process, one after another, each paced to
absolute deadlines every Ts (0.67 ms) by ``time.sleep`` as the services are, CPU from
``time.process_time``:

* ``wake_us``: a loop that only sleeps to the next deadline (the machine's cost of one timer
  wake-up; nothing else runs in it);
* ``plant_paced_us``: the full 50-turbine plant as the plant service builds it, one turbine remote:
  per sample ``apply_remote`` (new references), ``step()``, ``measurements()`` — the model's work
  of one plant-service step, without packets (``plant_warm_us``: the same back to back, no sleep);
* ``sdc_paced_us``: the SDC service's own ``receive`` + ``_serve`` of one MEAS datagram (admission,
  the Tustin step, CTRL packing; the CTRL handed to an in-memory socket) per sample
  (``sdc_warm_us``: back to back).

``floor_chain_us`` = ``plant_paced_us`` + ``sdc_paced_us``: two processes that each wake once per
sample and do only their model's work. The chain outside the switches measured in the network
(``cpu_budget.py``) adds the packets' system calls, the services' Python around them and the SDN
app; it cannot be below this floor. Compare with ``goal_us`` (#8: 100).

    .venv/bin/python benchmarks/wake_floor.py [--seconds 2] [--repeat 3]   # ~30 s
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # as the runner's services

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from plant_speed import _service_plant  # noqa: E402 - benchmarks/
from sdc_round_cost import MemorySocket, make_service, meas_stream  # noqa: E402
from sdc_throughput import TS, machine  # noqa: E402

from sdvisc import wire  # noqa: E402

GOAL_US = 100.0
REMOTE = np.array([20], dtype=np.intp)  # one farm turbine in remote mode (index 20: wt3_1)


def paced(work, n: int, sleep: bool = True) -> float:
    """CPU µs per iteration of ``work(k)``, each started at its own deadline every Ts."""
    t0 = time.time() + 0.005
    cpu0 = time.process_time()
    for k in range(n):
        if sleep:
            wait = t0 + k * TS - time.time()
            if wait > 0:
                time.sleep(wait)
        work(k)
    return (time.process_time() - cpu0) / n * 1e6


def plant_work():
    p = _service_plant(REMOTE)
    state = {"m": p.measurements()}

    def step(_k: int) -> None:
        m = state["m"]
        p.apply_remote(REMOTE, m["v_d"][REMOTE], m["v_q"][REMOTE], m["i_d"][REMOTE], m["i_q"][REMOTE])
        p.step()
        state["m"] = p.measurements()
    return step


def sdc_work(n: int):
    svc = make_service(1, MemorySocket(), "10.0.0.254")
    sender = ("10.0.1.1", wire.PORT_TURBINE)
    stream = [sample[0] for sample in meas_stream(1, n)]
    state = {"k": 0}

    def serve(_k: int) -> None:
        k = state["k"]
        now = k * TS
        svc._serve(svc.receive([(stream[k % n], sender)], now), now)
        state["k"] = k + 1
    return serve


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=2.0, help="wall seconds per paced measurement")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    n = int(args.seconds / TS)
    runs: dict[str, list[float]] = {k: [] for k in ("wake_us", "plant_paced_us", "plant_warm_us",
                                                    "sdc_paced_us", "sdc_warm_us")}
    for _ in range(args.repeat):
        runs["wake_us"].append(paced(lambda _k: None, n))
        plant = plant_work()
        runs["plant_warm_us"].append(paced(plant, n, sleep=False))
        runs["plant_paced_us"].append(paced(plant, n))
        sdc = sdc_work(2 * n + 10)
        runs["sdc_warm_us"].append(paced(sdc, n, sleep=False))
        runs["sdc_paced_us"].append(paced(sdc, n))
    out = {"benchmark": "wake_floor", "ts_s": TS, "samples_per_measurement": n, "repeat": args.repeat}
    out.update({k: round(statistics.median(v), 1) for k, v in runs.items()})
    out["runs"] = {k: [round(x, 1) for x in v] for k, v in runs.items()}
    out["floor_chain_us"] = round(out["plant_paced_us"] + out["sdc_paced_us"], 1)
    out["goal_us"] = GOAL_US
    out["floor_above_goal"] = out["floor_chain_us"] > GOAL_US
    out["machine"] = machine()
    print(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
