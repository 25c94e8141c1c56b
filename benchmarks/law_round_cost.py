"""CPU cost of one SDC round per law (issue 41): ``ControllerBank.step`` of N started slots on held
measurements, for every law of sdc_unit.laws with a bank, each engine of the generic trapezoid.

CPU time (``time.process_time``) of this process, so other work on the machine disturbs it less
than wall time; the result is not a real-time claim. JSON to stdout and, with ``--out``, to a file
(benchmarks/measured/law-round-cost-<date>.json).

    .venv/bin/python benchmarks/law_round_cost.py --out benchmarks/measured/law-round-cost-2026-12-06.json
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from sdc_unit.bank import ControllerBank  # noqa: E402
from sdc_unit.law_trapezoid import TrapezoidControllers  # noqa: E402
from sdc_unit.laws import LAWS  # noqa: E402
from sdvisc.jsonlines import write_json_atomic  # noqa: E402
from sdvisc.vocabulary import MEAS_FIELDS  # noqa: E402

TS = 0.67e-3
OP = {"v_d": 1.0, "v_q": 0.0, "i_d": 0.5, "i_q": 0.1, "p": 0.5, "q": -0.1, "v_dc": 1.0, "omega_meas": 1.0}


def round_cost_us(law: str, n: int, rounds: int, engine: str | None = None) -> float:
    """CPU µs per ``ControllerBank.step`` of ``n`` slots (``engine``: the generic trapezoid's)."""
    bank = ControllerBank(n + 1, TS, law=law)
    if engine is not None:
        bank.visc = TrapezoidControllers(LAWS[law], n + 1, TS, engine=engine)
    bank.warm_up()
    slots = np.arange(n)
    for s in slots:
        bank.start(int(s), {"mask": 0})
    rows = np.array([[OP[k]] * n for k in MEAS_FIELDS])
    bank.step(slots, rows)
    t0 = time.process_time()
    for _ in range(rounds):
        bank.step(slots, rows)
    return 1e6 * (time.process_time() - t0) / rounds


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rounds", type=int, default=2000)
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    rows = []
    for name, law in LAWS.items():
        engines = [None] if law.rhs is None or name == "visc" else ["compiled", "numpy"]
        for engine in engines:
            for n in (4, 50):
                rows.append({"law": name, "engine": engine or "the law's own", "n": n,
                             "cpu_us_per_round": round(round_cost_us(name, n, args.rounds, engine), 1)})
    res = {"what": "CPU µs per ControllerBank.step round, held measurements", "rounds": args.rounds,
           "load_1min": os.getloadavg()[0], "results": rows}
    print(json.dumps(res, indent=1))
    if args.out:
        write_json_atomic(args.out, res)
    return 0


if __name__ == "__main__":
    sys.exit(main())
