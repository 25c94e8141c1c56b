"""The compiled path (plant/kernels.py) against the general numpy path (Plant(jit=False)), its
reference for the branches the compiled path hands over (limiters, etc.; plant/equations.py).
Against references neither was derived from (solve_ivp, power balance): test_plant_compiled.py.

Both paths run the same 1.5 s with a load step, remote mode (held references, then the lost-
reference fall-back), an SLG fault on and off, an SCR change, hd_visc and back, a grid-EMF and an
AVR-reference step; every measurement and output must agree to rounding, and the compiled path
must have done most of the steps. A second case drives remote turbines with current references
(``remote_apply = "i_ref"``, the real-time service's setting).
"""

from dataclasses import replace

import numpy as np
import pytest

from plant.params import PlantParams
from plant.sim import Plant

IDX = np.arange(20, 24)
EVENTS = {
    0.10: lambda p: p.load_step(50.0),
    0.20: lambda p: (p.set_remote_fallback(False), p.set_mode(IDX, "remote")),
    0.35: lambda p: p.set_remote_fallback(True),
    0.50: lambda p: p.fault(True, z_f=0.01),
    0.60: lambda p: p.fault(False),
    0.80: lambda p: p.set_scr(4.0),
    0.95: lambda p: p.set_mode(IDX, "hd_visc"),
    1.15: lambda p: p.set_mode(IDX, "grid_following"),
    1.25: lambda p: p.set_grid_emf(0.98),
    1.35: lambda p: p.set_avr_ref(p.sc.v_ref + 0.02),
}


# remote turbines with remote_apply = "i_ref": local current loop on references sent every 5 steps
IREF_EVENTS = {
    0.05: lambda p: (p.set_remote_fallback(False), p.set_mode(IDX, "remote")),
    0.15: lambda p: p.load_step(30.0),
    0.30: lambda p: p.set_remote_fallback(True),
}


def _send_iref(p):
    i = p.measurements()
    p.apply_remote(IDX, np.zeros(4), np.zeros(4), 0.9 * i["i_d"][IDX], 0.9 * i["i_q"][IDX])


def _run(jit: bool, t_end: float = 1.5, record_every: int = 5, events=None, params=None, every5=None):
    p = Plant(params, n_turbines=50, jit=jit)
    counts = [0, 0]
    if jit:
        inner = p._compiled.step

        def counting(*a):
            r = inner(*a)
            counts[r is not None] += 1
            return r

        p._compiled.step = counting
    ev = {int(round(t / p.step_s)): f for t, f in (events or EVENTS).items()}
    meas, outs = [], []
    for k in range(int(round(t_end / p.step_s))):
        if k in ev:
            ev[k](p)
        if every5 is not None and k % 5 == 0 and 0.05 < k * p.step_s < 0.3:
            every5(p)
        p.step()
        meas.append(p.measurements())
        if k % record_every == 0:
            outs.append(p.outputs())
    return meas, outs, counts


def _max_rel_dev(a, b) -> float:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert np.array_equal(np.isnan(a), np.isnan(b))
    a, b = np.nan_to_num(a), np.nan_to_num(b)
    return float(np.max(np.abs(a - b)) / max(float(np.max(np.abs(b))), 1e-12))


def _iref_run(jit: bool):
    pp = PlantParams()
    pp.turbine = replace(pp.turbine, remote_apply="i_ref")
    return _run(jit, t_end=0.5, events=IREF_EVENTS, params=pp, every5=_send_iref)


@pytest.mark.parametrize("case", ["events", "remote_i_ref"])
def test_compiled_step_matches_numpy(case):
    run = _run if case == "events" else _iref_run
    (mj, oj, counts), (mn, on, _) = run(True), run(False)
    worst = {}
    for key in mn[0]:
        worst[key] = _max_rel_dev([m[key] for m in mj], [m[key] for m in mn])
    for key in on[0]:
        worst[key] = _max_rel_dev([o[key] for o in oj], [o[key] for o in on])
    print("\nmax relative deviation:", {k: f"{v:.1e}" for k, v in sorted(worst.items(), key=lambda kv: -kv[1])[:6]})
    print("compiled steps / numpy steps:", counts[True], counts[False])
    assert max(worst.values()) <= 1e-9, worst
    assert counts[True] > 0.5 * (counts[True] + counts[False])  # the compiled path did most steps


def test_measurement_arrays_are_not_overwritten():
    p = Plant(n_turbines=5)
    p.step()
    m = p.measurements()
    snap = {k: v.copy() for k, v in m.items()}
    p.load_step(20.0)
    for _ in range(3):
        p.step()
    assert all(np.array_equal(m[k], snap[k]) for k in m)
    assert not np.array_equal(p.measurements()["p"], snap["p"])
