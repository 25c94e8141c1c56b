"""F3.a's SC half (issue 28 item 10): how far the SC's terminal rises when its AVR reference steps
1.00 → 1.04 (the paper: ≈ 1.035, a rise of 0.035), for the two parameters that set it.

With reactive droop m_q the AVR holds V_t = V* − m_q Q and the step-up carries Q = (V_t − V_pcc)/x_tr,
so an ideal regulator lifts the terminal by 0.04 · x_tr / (x_tr + m_q) (0.0333 at x_tr = 0.10,
0.0353 at 0.15); a proportional exciter of gain K leaves a steady-state error of about E_fd / K
below that. The script runs report F3's SC case (`plant.cases`-style farm with the SC, 6 s, the step
at 1 s) for K in the range claim_sensitivity.py gives the static exciter (100-400, Kundur's two-area
SEXS K = 200 the default) and beyond it, and for x_tr over IEC 60076-5's 0.10-0.15 at this rating,
and prints the rise and its verdict against 0.035 (within 10 % = yes). Offline, one process.

    PYTHONPATH=. python benchmarks/f3_sc_sensitivity.py > benchmarks/measured/f3-sc-sensitivity-DATE.json
"""

from __future__ import annotations

import json
import sys
import time

from plant.params import PlantParams
from plant.sim import Plant

PAPER_RISE = 0.035
CASES = [{"avr_k": k, "x_tr": x} for x in (0.10, 0.12, 0.15) for k in (100.0, 200.0, 400.0, 1000.0)]


def sc_rise(avr_k: float, x_tr: float, t_end: float = 6.0) -> dict:
    pp = PlantParams(sc_connected=True)
    pp.condenser.avr_k, pp.condenser.x_tr = avr_k, x_tr
    plant = Plant(pp)
    ref0 = plant.sc.v_ref
    r = plant.run_offline(t_end, events=[(1.0, lambda q: q.set_avr_ref(ref0 + 0.04))], record_every=10)
    v, before = r["v_sc"], r["t"] < 1.0
    rise = float(v[-1] - v[before][-1])
    ideal = 0.04 * x_tr / (x_tr + pp.condenser.m_q)
    return {"avr_k": avr_k, "x_tr": x_tr, "v_before": round(float(v[before][-1]), 4), "v_after": round(float(v[-1]), 4),
            "rise": round(rise, 4), "ideal_rise": round(ideal, 4), "off_paper_pct": round((rise / PAPER_RISE - 1) * 100, 1),
            "within_10pct": abs(rise / PAPER_RISE - 1) <= 0.10}


def main() -> int:
    t0 = time.time()
    result = {"benchmark": "f3_sc_sensitivity", "paper_rise": PAPER_RISE,
              "defaults": {"avr_k": 200.0, "x_tr": 0.12, "m_q": 0.02},
              "cases": [sc_rise(**c) for c in CASES]}
    result["wall_s"] = round(time.time() - t0, 1)
    print(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
