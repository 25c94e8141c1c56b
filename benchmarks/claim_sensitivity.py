"""Sensitivity of every printed number of the paper the offline testbed does not reproduce within 10 %
(issue 28, build item 10; issue 39: over structure as well as values): which defensible parameters move
it, each over the range its source allows, which structural alternatives the paper leaves open move it,
and whether any defensible value reaches the paper's number.

One-at-a-time (tornado): every parameter at the low and at the high end of its range, the others at
their defaults; then the "best corner" (each range parameter at whichever end moved the number
towards the paper, all together). Two kinds of variation, kept apart in the output:

* ``range``: a parameter with a source and a range (``Param.source`` says which and why);
* ``open choice``: an alternative the paper leaves open — the plant controller's model (IEC 61400-27-1
  / legacy / off / no dip freeze / Q mode), its Q limitation, communication delay and a k_i re-tuned
  for the SCR, step vs slow ramp, the SC's AVR bus, virtual friction (F7.a/b/c, F9.c/d); the bus,
  fault type, fault resistance over the cited 0-50 ohm and the reading (V1 / per phase) (F6.d, F8.c);
  which bus or measure a figure shows. These are alternatives, not ranges: never combined into the
  corner, and a number only one of them reaches is "consistent", not "yes".

Every run is offline (plant.cases, the continuous law hd_visc), in this one process, measured the way
its report experiment measures it (report/exp_grid.py, exp_weak.py, f7_second_look.py, f7_mechanism.py,
exp_parallel.py, fault_readings.py, exp_cyber.py), with the report's stability criterion
(report/stability.py), bisection (report/boundary.py) and verdict rules (report/verdicts.py). The code
is the package benchmarks/sensitivity/ (one module per part); this file is its command.

Usage (from the checkout; report/ is not an installed package):
    PYTHONPATH=. nice -n 5 .venv/bin/python benchmarks/claim_sensitivity.py [--out DIR] [--date YYYY-MM-DD]
        [--only F6.d,F7,F8,F9,C1.b] [--redraw]
Writes DIR/claim-sensitivity-<date>.json and one PNG per claim (DIR/<claim>-<date>.png); default DIR
benchmarks/measured/claim-sensitivity/.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # the checkout: benchmarks/, plant/, report/

from benchmarks.sensitivity.cli import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:], __doc__))
