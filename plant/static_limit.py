"""The farm's static transfer limit: the lowest SCR at which its export still has a load-flow
solution (the nose of its P–V curve), reported beside the dynamic stability boundaries of F7 so a
loss of stability can be told apart from running out of transfer capacity (issue 28 item 2).

Continuation on the SCR from the plant's own operating point: each step's load flow starts from the
last solution; the SCR at which it stops converging is bisected to ``xtol``. The load flow
(issue 39: with the devices' limits, not PQ sources without them):

* grid-following turbines: P* (the MPPT curve) and the plant controller's order at its capacitive
  limit ``WppParams.q_max`` cut by each turbine's Q limitation at its terminal voltage
  (``wpp.q_limit_at``), the current limited to ``TurbineParams.i_max_gfl`` (circular: P and Q
  scaled down together, the normal-operation law of ``turbine_laws.gfl_current_ref``);
* SDViSC units (``hd_visc`` turbines): their whole current limit ``ViscParams.i_max`` as capacitive
  current (P = 0), the most a voltage-forming unit can give;
* the synchronous condenser: its rated reactive output (1.0 p.u. on its 40 MVA rating), the AVR at
  its most in steady state (the field ceiling would give more for seconds, not continuously).

``limits=False`` gives the former load flow (``Plant._load_flow``: PQ sources without a current
limit, the SC unloaded) for comparison.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import root

from plant import turbine as T
from plant.sim import Plant
from plant.wpp import q_limit_at


def _limited_load_flow(plant: Plant, start):
    """Node voltages of the load flow with the devices' limits (see the module's docstring), or
    raise RuntimeError if it does not converge."""
    n, net, g = plant.n, plant.net, plant.params
    tb, wp = plant.tb, g.wpp
    p_me = tb.p_star(tb.wr0())
    i_max = g.turbine.i_max_gfl
    visc = tb.mode == T.HD_VISC
    i_visc = (plant.visc_params.i_max if plant.visc_params is not None else 1.5)
    mask = plant._wpp_mask & ~visc

    def residual(x):
        vall = x[:net.n_nodes] + 1j * x[net.n_nodes:]
        v = np.where(net.plugged, vall[:n], 1.0)
        vm = np.maximum(np.abs(v), 1e-3)
        q = tb.q_cmd + np.where(mask, np.minimum(wp.q_max, q_limit_at(vm, wp)) if plant.wpp is not None else 0.0, 0.0)
        i = np.conj((p_me + 1j * q) / v)
        i *= np.minimum(1.0, i_max / np.maximum(np.abs(i), 1e-9))
        i = np.where(visc, -1j * i_visc * v / vm, i)
        e_sc = 0.0
        if net.sc_connected:
            v_sc = vall[net.sc]
            e_sc = v_sc * (1.0 + g.condenser.xd2 * 1.0 / max(abs(v_sc), 1e-3) ** 2)  # Q = 1.0 on its rating
        r = net.solve(net.injections(i, g.grid.e_grid, e_sc, 0.0)) - vall
        return np.r_[r.real, r.imag]

    x0 = np.r_[np.ones(net.n_nodes), np.zeros(net.n_nodes)] if start is None else np.r_[start.real, start.imag]
    sol = root(residual, x0, method="hybr", tol=1e-12)
    if np.max(np.abs(residual(sol.x))) > 1e-9:
        raise RuntimeError(f"no load-flow solution ({sol.message})")
    return sol.x[:net.n_nodes] + 1j * sol.x[net.n_nodes:]


def static_limit(plant: Plant, scr_from: float | None = None, step: float = 0.1, xtol: float = 0.005,
                 limits: bool = True) -> float:
    """The lowest SCR (within ``xtol``) with a load-flow solution for ``plant``'s P*/Q* (the plant's
    network is changed; build a fresh plant for anything else)."""
    wpp = plant.params.wpp
    if plant.wpp is not None and not limits:
        plant.tb.q_wpp[:] = wpp.q_max * plant._wpp_mask
    scr = plant.net.scr if scr_from is None else scr_from

    def solve(s: float, start):
        plant.net.set_scr(s)
        plant.net.ensure()
        try:
            return _limited_load_flow(plant, start) if limits else plant._load_flow(start)[2]
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
