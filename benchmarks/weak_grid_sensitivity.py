"""Weak-grid sensitivity (issue 28 item 10, a first step): where the farm, the SC case and the 40 MVA
SDViSC case stop being stable after SCR 7.14 -> s at 1 s, for parameter variations within their
sources' ranges. Prints one JSON object: per variation and case, the stability (report/stability.py)
at each SCR of a coarse grid. Offline, ~0.5 s per run.

Usage (from the checkout; report/ is not an installed package):
    PYTHONPATH=. .venv/bin/python benchmarks/weak_grid_sensitivity.py [SCR ...]   (default 2.1 1.9 1.8 1.7 1.6 1.5)
"""

from __future__ import annotations

import json
import sys

import plant.cases as cases
from report.stability import of_run

VARIATIONS = {  # name: {params-object.field: value}, each within the range its source allows
    "defaults": {},
    "SC stiff (x''d 0.12, x'd 0.20, x_tr 0.08: low end of typical machines)": {
        "condenser.xd2": 0.12, "condenser.xd1": 0.20, "condenser.x_tr": 0.08},
    "PLL 47 rad/s (k_p 0.15, k_i 3.6)": {"turbine.kp_pll": 0.15, "turbine.ki_pll": 3.6},
    "PLL 157 rad/s (k_p 0.5, k_i 40)": {"turbine.kp_pll": 0.5, "turbine.ki_pll": 40.0},
    "FRT k = 4": {"turbine.frt_k_qv": 4.0},
    "plant controller k_i 30": {"wpp.k_i": 30.0},
}
CASES = {"none": "bare_plant", "SC": "sc_plant", "SDViSC": "comparison_visc_plant"}


def _case(case: str, changes: dict, scr: float) -> str:
    make = getattr(cases, CASES[case])
    original = cases._params

    def changed(sc_connected, grid):
        pp = original(sc_connected, grid)
        for key, value in changes.items():
            part, field = key.split(".")
            setattr(getattr(pp, part), field, value)
        return pp

    cases._params = changed
    try:
        plant = make()
    finally:
        cases._params = original
    r = plant.run_offline(6.0, events=[(1.0, lambda q: q.set_scr(scr))], record_every=10)
    return of_run(r, 1.0).state


def main(argv: list[str]) -> None:
    scrs = [float(a) for a in argv] or [2.1, 1.9, 1.8, 1.7, 1.6, 1.5]
    out = {name: {case: {f"{s:g}": _case(case, changes, s) for s in scrs} for case in CASES}
           for name, changes in VARIATIONS.items()}
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main(sys.argv[1:])
