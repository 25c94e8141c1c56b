"""The farm's static transfer limit: the lowest SCR at which its export still has a load-flow
solution (the nose of its P–V curve), reported beside the dynamic stability boundaries of F7 so a
loss of stability can be told apart from running out of transfer capacity (issue 28 item 2).

Continuation on the SCR from the plant's own operating point: each step's load flow
(``Plant._load_flow``, every turbine a PQ source at its present P*/Q*, the plant controller's order
held at its capacitive limit ``WppParams.q_max`` — the most a static operating point can get) starts
from the last solution; the SCR at which it stops converging is bisected to ``xtol``.
"""

from __future__ import annotations

from plant.sim import Plant


def static_limit(plant: Plant, scr_from: float | None = None, step: float = 0.1, xtol: float = 0.005) -> float:
    """The lowest SCR (within ``xtol``) with a load-flow solution for ``plant``'s P*/Q* (the plant's
    network is changed; build a fresh plant for anything else)."""
    wpp = plant.params.wpp
    if plant.wpp is not None:
        plant.tb.q_wpp[:] = wpp.q_max * plant._wpp_mask
    scr = plant.net.scr if scr_from is None else scr_from

    def solve(s: float, start):
        plant.net.set_scr(s)
        plant.net.ensure()
        try:
            return plant._load_flow(start)[2]
        except RuntimeError:
            return None

    last = solve(scr, None)
    if last is None:
        raise RuntimeError(f"no load-flow solution at the starting SCR {scr}")
    while True:  # walk down until it fails
        found = solve(scr - step, last)
        if found is None:
            break
        scr, last = scr - step, found
        if scr - step <= 0.0:
            return scr
    lo, hi, at_hi = scr - step, scr, last
    while hi - lo > xtol:
        mid = 0.5 * (lo + hi)
        found = solve(mid, at_hi)
        if found is None:
            lo = mid
        else:
            hi, at_hi = mid, found
    return hi
