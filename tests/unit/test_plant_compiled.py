"""The compiled path (plant/kernels.py) against references it was not derived from.

1. scipy's solve_ivp (RK45, rtol 1e-8) on the general path's right-hand side (``Plant.rhs_real``)
   for three turbines of a farm -- grid-following, remote (held reference, v_ref or i_ref) and
   hd_visc (sdc_unit.law) -- with the condenser, a grid-EMF step, an AVR step with a new current
   reference for the remote turbine (applied with remote_apply "i_ref") and a load step,
   the slow terms evaluated every step (``slow_every=1``). Stated tolerance, RMS error of each
   turbine's current and of v_dc^2 over their RMS at the plant's step: 1e-3 grid-following,
   1e-2 hd_visc and remote i_ref, 3e-2 remote v_ref (measured 2.2e-2: the undamped voltage-source
   filter mode, h*lambda = 0.42j, on which the explicit stage's phase error dominates); law states
   1e-3 absolute. And the order: halving the step divides every error by more than 3 (ETD2 is
   second order: measured 4.1-4.3), so the compiled trajectories converge to the reference and no
   equation differs from it.
2. Power balance at every step of a transient on the 50-turbine farm (four turbines remote and
   back, grid-EMF, AVR and power-reference steps): turbine power = power into
   the grid + series losses - condenser power, relative error 1e-9. The turbine powers come from
   the compiled network solve, the rest from the full numpy solve of ``outputs()``.
3. The load-flow steady state (closed forms and a full-Y solve, plant/sim.py) is a fixed point of
   the compiled right-hand side: max |dX| < 1e-8.
Each test also checks that the compiled path did (nearly) all the evaluations.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from plant.compiled import CompiledAux
from plant.params import PlantParams
from plant.sim import Plant

DT = 0.67e-3
N = 3  # 0 grid-following, 1 remote, 2 hd_visc
GFL, REMOTE, VISC = 0, 1, 2


def _new_i_ref(q):
    """The remote turbine's held current reference (its current when it went remote, the same in
    every run) times 1.02 + 0.05j, its held v_ref unchanged (used with remote_apply "i_ref")."""
    v, i = q.tb.v_hold[[REMOTE]], q.tb.i_hold[[REMOTE]] * (1.02 + 0.05j)
    q.apply_remote([REMOTE], v.real, v.imag, i.real, i.imag)


EVENTS = {45: lambda q: q.set_grid_emf(0.97), 120: lambda q: (q.set_avr_ref(q.sc.v_ref + 0.01), _new_i_ref(q)),
          195: lambda q: q.load_step(10.0)}  # at step k of DT
K_END = 300


def _three(remote_apply: str, step_s: float = DT) -> Plant:
    pp = PlantParams()
    pp.turbine.remote_apply = remote_apply
    pp.wpp.enabled = False  # the plant's voltage controller is sampled, outside the ODE (tests/unit/test_plant_wpp.py)
    # as in test_plant_ivp: the ViSC at P = 0 may motor and draw on the rotor, so that neither the
    # MSC clip nor the chopper (kinks the implicit reference solver cannot step across) acts
    pp.turbine.p_me_min = -1.0
    pp.turbine.p_headroom = 1.1
    p = Plant(pp, n_turbines=N, step_s=step_s, slow_every=1)
    p.set_power_ref(VISC, p=0.0)
    p.reinitialise()
    p.set_mode(VISC, "hd_visc")
    p.set_remote_fallback(False)
    p.set_mode(REMOTE, "remote")
    return p


def _count_general(p: Plant) -> list:
    count = [0]
    general = p._rhs_general

    def counting(*a, **kw):
        count[0] += 1
        return general(*a, **kw)

    p._rhs_general = counting
    return count


def _run_plant(p: Plant, div: int):
    """States at every DT (the plant steps DT/div); also the number of general-path evaluations."""
    general = _count_general(p)
    events = {k * div: f for k, f in EVENTS.items()}
    ys = [p.state_real()]
    for k in range(K_END * div):
        if k in events:
            events[k](p)
        p.step()
        if (k + 1) % div == 0:
            ys.append(p.state_real())
    return np.array(ys), general[0]


def _run_ivp(p: Plant):
    y = p.state_real()
    out = [y]
    k0 = 0
    for km in [*sorted(EVENTS), K_END]:
        # RK45, not BDF: the same rtol, a quarter of the time (BDF's finite-difference Jacobians of 102 states
        # dominated). Against DOP853 at rtol 1e-11 its errors (as _errors measures them) are <= 9e-8 for the
        # currents and v_dc^2 and 1.3e-8 for the law states (measured, both remote_apply): over a thousand
        # times below the compiled path's smallest error at h/2 (5.9e-6), so neither the tolerances nor the
        # convergence ratios move (all as with BDF to the digits printed).
        sol = solve_ivp(p.rhs_real, (k0 * DT, km * DT), y, method="RK45", t_eval=np.arange(k0 + 1, km + 1) * DT,
                        rtol=1e-8, atol=1e-10, max_step=2e-3)
        assert sol.success, sol.message
        out.extend(sol.y.T)
        y = sol.y[:, -1]
        p.set_state_real(y)
        if km in EVENTS:
            EVENTS[km](p)
        k0 = km
    return np.array(out)


def _errors(ya, yb, size):
    """Per turbine: RMS error / RMS of the current and of v_dc^2; max error of the law states."""
    i_a, i_b = ya[:, :N] + 1j * ya[:, size:size + N], yb[:, :N] + 1j * yb[:, size:size + N]
    w_a, w_b = ya[:, 4 * N:5 * N], yb[:, 4 * N:5 * N]  # turbine.W row: v_dc^2
    e_i = np.sqrt(np.mean(np.abs(i_a - i_b) ** 2, axis=0) / np.mean(np.abs(i_b) ** 2, axis=0))
    e_w = np.sqrt(np.mean((w_a - w_b) ** 2, axis=0) / np.mean(w_b**2, axis=0))
    return e_i, e_w, float(np.max(np.abs(ya[:, 2 * size:] - yb[:, 2 * size:])))


@pytest.mark.slow
@pytest.mark.parametrize("remote_apply", ["v_ref", "i_ref"])
def test_compiled_path_converges_to_solve_ivp(remote_apply):
    ref = _run_ivp(_three(remote_apply))
    size = _three(remote_apply).size
    errs = []
    for div in (1, 2):
        y, general = _run_plant(_three(remote_apply, DT / div), div)
        assert general <= 0.02 * K_END * div, f"the compiled path must do the evaluations ({general} general)"
        errs.append(_errors(y, ref, size))
    (e_i, e_w, e_law), (e_i2, e_w2, e_law2) = errs
    print(f"\nremote {remote_apply}: current error {e_i}, v_dc^2 {e_w}, law {e_law:.1e};"
          f" ratios at h/2 {e_i / e_i2}, {e_w / e_w2}, {e_law / e_law2:.2f}")
    swing = np.ptp(np.abs(ref[:, :N] + 1j * ref[:, size:size + N]), axis=0)
    assert np.all(swing > 0.015), "the events must excite every turbine"
    limit_remote = 3e-2 if remote_apply == "v_ref" else 1e-2
    assert e_i[GFL] < 1e-3 and e_w[GFL] < 1e-3
    assert e_i[REMOTE] < limit_remote and e_w[REMOTE] < limit_remote
    assert e_i[VISC] < 1e-2 and e_w[VISC] < 1e-2 and e_law < 1e-3
    assert np.all(e_i / e_i2 > 3.0) and np.all(e_w / e_w2 > 3.0) and e_law / e_law2 > 3.0


def test_power_balance_at_every_step_of_a_transient():
    p = Plant(n_turbines=50)
    general = _count_general(p)
    kt = p.params.turbine.s_rated_mva / p.params.grid.s_base_mva
    ksc = p.params.condenser.s_rated_mva / p.params.grid.s_base_mva
    idx = np.arange(20, 24)
    events = {30: lambda q: (q.set_remote_fallback(False), q.set_mode(idx, "remote")),
              100: lambda q: q.set_grid_emf(0.97), 200: lambda q: q.set_avr_ref(q.sc.v_ref + 0.02),
              300: lambda q: q.set_power_ref([0, 1], p=0.9, q=0.1), 400: lambda q: q.set_mode(idx, "grid_following")}
    worst, p_min, p_max = 0.0, np.inf, -np.inf
    for k in range(500):
        if k in events:
            events[k](p)
        p.step()
        o = p.outputs()
        p_turbines = np.sum(o["p_wt"]) * kt
        balance = o["p_grid"] + o["losses"] - o["p_sc"] * ksc
        worst = max(worst, abs(p_turbines - balance) / abs(p_turbines))
        p_min, p_max = min(p_min, o["p_grid"]), max(p_max, o["p_grid"])
    print(f"\npower balance: worst relative mismatch {worst:.1e}; P_grid {p_min:.4f}..{p_max:.4f};"
          f" general-path evaluations {general[0]} of {500 * 2}")
    assert worst < 1e-9
    assert p_max - p_min > 0.01, "the events must move the power flow"
    assert general[0] <= 0.02 * 500


def test_load_flow_steady_state_is_a_fixed_point_of_the_compiled_rhs():
    p = Plant(n_turbines=50)
    dX, _, aux = p._eval_cached()
    assert isinstance(aux, CompiledAux), "the compiled path evaluated it"
    print(f"\nmax |dX| at the load-flow steady state: {np.max(np.abs(dX)):.1e}")
    assert np.max(np.abs(dX)) < 1e-8
