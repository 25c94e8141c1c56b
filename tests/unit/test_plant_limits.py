"""The compiled path (plant/kernels.py, turbine_kernels.py) where the limiters and the DC-link
batteries act, against the general numpy path (Plant(jit=False)); both run the limiter and battery
equations of plant/turbine_laws.py, the numpy path on arrays, the kernels compiled per turbine.

1. F5 (docs/report.md): four hd_visc SDViSCs with batteries at a 1 C current limit, a 100 MW load
   step; the battery current reaches its limit.
2. A weak grid (SCR 2) with an SLG fault: the 50 grid-following turbines run at their current
   limit, and in the fault the V_d floor, the modulation limit and the braking chopper act.

Stated tolerance: every measurement, output, SOC, delivered energy and law state within 1e-9 of
the numpy path's, relative to the largest magnitude of that quantity (as tests/unit/
test_plant_jit.py; the two paths round differently: numpy's whole-array operations against the
kernels' per-turbine ones). The compiled path must have taken every step and evaluation
(``covers()`` true throughout), so the limiters and batteries do not leave it.
"""

import numpy as np

from plant.params import PlantParams
from plant.sim import Plant
from sdc_unit.params import ViscParams

VISC = np.arange(20, 24)
RTOL = 1e-9


def _track(p: Plant) -> list[int]:
    """[general-path evaluations, compiled steps] of plant ``p`` from now on."""
    counts = [0, 0]
    general = p._rhs_general

    def counting_general(*a, **kw):
        counts[0] += 1
        return general(*a, **kw)

    p._rhs_general = counting_general
    if p._compiled is not None:
        for name in ("step", "step_evaluating_first_stage"):  # from the cached first stage, or evaluating it
            step = getattr(p._compiled, name)

            def counting_step(*a, step=step):
                counts[1] += 1
                return step(*a)

            setattr(p._compiled, name, counting_step)
    return counts


def _run(p: Plant, events: dict, steps: int) -> tuple[dict, list, list]:
    """Per step: the measurements, the law states, SOC, energy, and (``covers()``); every 5th
    step the outputs. Returns (records, counts, covered)."""
    counts = _track(p)
    rec: dict[str, list] = {}
    covered = []
    for k in range(steps):
        if k in events:
            events[k](p)
        p.step()
        for key, val in p.measurements().items():
            rec.setdefault(key, []).append(val)
        rec.setdefault("soc", []).append(p.tb.batt.soc.copy())
        rec.setdefault("energy", []).append(p.tb.batt.energy.copy())
        if p.xl is not None:
            rec.setdefault("xl", []).append(p.xl.copy())
        aux = p._eval_cached()[2]
        rec.setdefault("v_conv_mag", []).append(np.abs(aux["vconv"]))
        if p._compiled is not None:
            covered.append(p._compiled.covers(p.tb, p.net))
        if k % 5 == 0:
            o = p.outputs()
            for key in ("v_pcc", "f_pcc_hz", "p_grid", "q_grid", "p_batt", "p_me", "i_wt", "e_batt_mwh"):
                rec.setdefault("out_" + key, []).append(o[key])
    return {key: np.array(v) for key, v in rec.items()}, counts, covered


def _max_rel_dev(a, b) -> float:
    return float(np.max(np.abs(a - b)) / max(float(np.max(np.abs(b))), 1e-12))


def _compare(case, steps: int, events: dict):
    """Run ``case(jit)`` both ways; assert the stated tolerance and full coverage; return the
    compiled run's records."""
    compiled, counts, covered = _run(case(True), events, steps)
    numpy_path, _, _ = _run(case(False), events, steps)
    worst = {key: _max_rel_dev(compiled[key], numpy_path[key]) for key in numpy_path}
    print("\nmax relative deviation:", {k: f"{v:.1e}" for k, v in sorted(worst.items(), key=lambda kv: -kv[1])[:5]},
          f"general-path evaluations {counts[0]}, compiled steps {counts[1]} of {steps}")
    assert max(worst.values()) <= RTOL, worst
    assert all(covered) and len(covered) == steps, "covers() must hold at every step"
    assert counts == [0, steps], "the compiled path must take every step and evaluation"
    return compiled


def _f5(jit: bool) -> Plant:
    pp = PlantParams(sc_connected=False)
    pp.grid.h_grid, pp.grid.s_grid_mva = 5.0, 1000.0
    pp.battery.c_rate_discharge = 1.0
    pp.visc_params = ViscParams(h=4.0)
    p = Plant(pp, jit=jit)
    p.set_power_ref(VISC, p=0.0)
    p.reinitialise()
    p.set_battery(VISC, True)
    p.set_mode(VISC, "hd_visc")
    return p


def test_battery_plant_compiled_matches_numpy():
    """F5 with a 1 C battery limit (0.22 p.u.): +100 MW at 0.1 s, 0.5 s. The battery discharges up
    to its C-rate limit (the clip acts), the SOC falls, and the compiled path matches numpy."""
    rec = _compare(_f5, 750, {150: lambda q: q.load_step(100.0)})
    p = _f5(True)
    i_b = rec["out_p_batt"][:, VISC] / rec["v_dc"][::5, VISC]  # outputs are recorded every 5th step
    assert abs(np.max(i_b) / p.tb.batt.i_dis_max - 1.0) < 1e-12, "the C-rate limit acted"
    assert np.all(rec["soc"][-1, VISC] < 0.5) and np.all(rec["energy"][-1, VISC] > 0.0)
    others = np.setdiff1d(np.arange(p.n), VISC)
    assert np.all(rec["out_p_batt"][:, others] == 0.0) and np.all(rec["soc"][:, others] == 0.5)


def _weak(jit: bool) -> Plant:
    pp = PlantParams()
    pp.wpp.enabled = False  # the turbines at their own limit, not the plant controller's (its tests: test_plant_wpp.py)
    pp.turbine.frt_k_qv = 0.0  # P-priority limiting here; FRT's Q priority: test_plant_wpp.py
    p = Plant(pp, n_turbines=50, jit=jit)
    p.set_scr(2.0)
    return p


def test_weak_grid_limiters_compiled_match_numpy():
    """SCR 2, an SLG fault from 0.2 s to 0.25 s, 0.4 s. Before the fault the MPPT reference
    (P* / V_d with V_d ~ 0.35) is far above i_max_gfl = 1.1: every grid-following current sits at
    the limit (within 1.5 % from 0.1 s on: the active damping's k_ad (v - phi) is a disturbance the
    current PI's integral removes over kpc/kic ~ 0.09 s); in the fault V_d falls below the 0.3 floor, the converter voltages reach the
    modulation limit m_max v_dc and the DC links rise above the chopper threshold."""
    rec = _compare(_weak, 600, {300: lambda q: q.fault(True, z_f=0.01), 375: lambda q: q.fault(False)})
    tp = PlantParams().turbine
    i_mag = np.hypot(rec["i_d"], rec["i_q"])
    pre_fault = i_mag[150:300]
    assert np.all(np.abs(pre_fault / tp.i_max_gfl - 1.0) < 1.5e-2), "current limit: |i| at i_max before the fault"
    assert np.all(pre_fault <= tp.i_max_gfl * (1.0 + 1e-9)), "never above it"
    assert np.min(np.hypot(rec["v_d"], rec["v_q"])) < 0.3, "V_d <= |v| below the V_d floor"
    assert np.max(rec["v_conv_mag"] / (tp.m_max * rec["v_dc"])) > 1.0 - 1e-12, "modulation limit acted"
    assert np.max(rec["v_dc"]) > tp.v_chop, "chopper acted"
