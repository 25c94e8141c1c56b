"""CPU per plant step (step() + measurements(), process CPU, 3000 steps after 300 of warm-up) of one
case at the plant's normal 0.67 ms step, for before/after figures of a plant change with farm-bench:

    farm-bench -n 6 --timeout 300 \
      --vs "sh -c 'exec .venv/bin/python benchmarks/plant_step_cpu.py OLD_CHECKOUT battery >>/tmp/b.txt'" \
      -- sh -c 'exec .venv/bin/python benchmarks/plant_step_cpu.py . battery >>/tmp/a.txt'

Usage: python benchmarks/plant_step_cpu.py CHECKOUT {gfl,hd_visc,battery}; prints one JSON line.
gfl = the farm alone; hd_visc = four SDViSCs of cluster 3 (the continuous law); battery = the same
with their batteries (F5). 20x real time = 33.5 us per step.
"""

from __future__ import annotations

import json
import os
import sys
import time

STEPS, WARM_UP = 3000, 300


def main(checkout: str, mode: str) -> None:
    sys.path.insert(0, checkout)  # the checkout whose plant is measured (before/after pairs)
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    import plant.cases as cases

    make = {"gfl": cases.bare_plant, "hd_visc": lambda: cases.visc_plant(4),
            "battery": lambda: cases.visc_plant(4, battery=True)}[mode]
    p = make()
    for _ in range(WARM_UP):
        p.step()
    t0 = time.process_time()
    for _ in range(STEPS):
        p.step()
        p.measurements()
    print(json.dumps({"mode": mode, "cpu_us_per_step": (time.process_time() - t0) / STEPS * 1e6}))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
