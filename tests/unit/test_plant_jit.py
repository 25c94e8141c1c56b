"""The compiled path (plant/kernels.py) against the general numpy path (Plant(jit=False)), its
reference for the branches the compiled path hands over (limiters, etc.; plant/equations.py).
Against references neither was derived from (solve_ivp, power balance): test_plant_compiled.py.

Both paths run the same 1.5 s with a load step, remote mode (held references, then the lost-
reference fall-back), an SLG fault on and off, an SCR change, hd_visc and back, a grid-EMF and an
AVR-reference step; every measurement and output must agree to rounding, and the compiled path
must have done most of the steps. A second case drives remote turbines with current references
(``remote_apply = "i_ref"``, the real-time service's setting). A third runs four hd_visc turbines
with the ViSC law compiled into the step (plant/visc_kernels.py) against the law in numpy
(``compiled_law = False``: the path before, the law between two kernels) and against ``jit=False``.
"""

from dataclasses import replace

import numpy as np
import pytest

from plant.params import PlantParams
from plant.sim import Plant
from sdc_unit.params import ViscParams

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
    0.15: lambda p: p.set_grid_emf(0.98),
    0.30: lambda p: p.set_remote_fallback(True),
}


def _send_iref(p):
    i = p.measurements()
    p.apply_remote(IDX, np.zeros(4), np.zeros(4), 0.9 * i["i_d"][IDX], 0.9 * i["i_q"][IDX])


def _count_compiled_steps(p) -> list[int]:
    """[numpy-path steps, compiled steps] of plant ``p`` from now on (counted around its compiled
    steps: from the cached first stage, and with the first stage evaluated in the same call)."""
    counts = [0, 0]
    if p._compiled is not None:
        inner, fused = p._compiled.step, p._compiled.step_evaluating_first_stage

        def counting(*a):
            r = inner(*a)
            counts[r is not None] += 1
            return r

        def counting_fused(*a):
            counts[True] += 1
            return fused(*a)

        p._compiled.step = counting
        p._compiled.step_evaluating_first_stage = counting_fused
    return counts


def _run(jit: bool, t_end: float = 1.5, record_every: int = 5, events=None, params=None, every5=None):
    p = Plant(params, n_turbines=50, jit=jit)
    counts = _count_compiled_steps(p)
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


# four hd_visc turbines (P* = 0) from t = 0: load step, grid-EMF step, new law parameters (droop, V*:
# the compiled law's parameters re-packed), then an SLG fault (the law's current limiter acts; the
# grid-following turbines' limiters send those steps and the recovery to the numpy path; an SCR
# change would too: their choppers act for ~0.1-0.2 s after it)
VISC_EVENTS = {
    0.05: lambda p: p.load_step(50.0),
    0.15: lambda p: p.set_grid_emf(0.98),
    0.25: lambda p: p.set_visc_params(ViscParams(m_q=0.05, v_ref=1.01)),
    0.40: lambda p: p.fault(True, z_f=0.002),
    0.45: lambda p: p.fault(False),
}


def _visc_run(variant: str, t_end: float = 0.5):
    """Per step: V_pcc, Q of the hd_visc turbines, their law states and |E|; and the number of
    steps the compiled hd_visc step did / handed to numpy."""
    p = Plant(n_turbines=50, jit=variant != "numpy")
    p.set_power_ref(IDX, p=0.0)
    p.reinitialise()
    p.set_mode(IDX, "hd_visc")
    p.compiled_law = variant == "compiled"
    counts = _count_compiled_steps(p)
    ev = {int(round(t / p.step_s)): f for t, f in VISC_EVENTS.items()}
    rec = {"v_pcc": [], "q": [], "xl": [], "e_mag": [], "limited": []}
    for k in range(int(round(t_end / p.step_s))):
        if k in ev:
            ev[k](p)
        p.step()
        aux = p._eval_cached()[2]
        rec["v_pcc"].append(abs(aux["v_pcc"]))
        rec["q"].append(p.measurements()["q"][IDX])
        rec["xl"].append(p.xl.copy())
        rec["e_mag"].append(aux["law_out"].e_mag)
        rec["limited"].append(aux["law_out"].limited)
    return {key: np.array(v) for key, v in rec.items()}, counts


def test_compiled_law_matches_numpy_law():
    """The compiled hd_visc step (law compiled in) gives the trajectory of the law in numpy: V_pcc,
    Q of the hd_visc turbines, law states and |E| within 1e-9 relative (measured: a few 1e-15,
    rounding) over 0.5 s with a load step, a grid-EMF step, new law parameters and a fault with the
    law's current limiter acting; the compiled hd_visc step did every step before the fault."""
    compiled, counts = _visc_run("compiled")
    assert counts[True] >= int(round(0.40 / 0.67e-3)), counts
    assert compiled["limited"].any()  # the limiter acted
    for variant in ("numpy_law", "numpy"):
        ref, _ = _visc_run(variant)
        assert np.array_equal(compiled["limited"], ref["limited"]), variant
        worst = {key: _max_rel_dev(compiled[key], ref[key]) for key in ("v_pcc", "q", "xl", "e_mag")}
        print(f"\ncompiled law vs {variant}: max relative deviation", {k: f"{v:.1e}" for k, v in worst.items()},
              "compiled steps / numpy steps:", counts[True], counts[False])
        assert max(worst.values()) <= 1e-9, (variant, worst)
