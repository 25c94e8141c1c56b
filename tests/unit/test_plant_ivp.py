"""One turbine on an infinite bus: the fixed-step plant against scipy.integrate.solve_ivp (item 2).

The same right-hand side (Plant.rhs_real) is integrated by solve_ivp (Radau, tight tolerances) in
segments between the events; the plant runs its own ETD2/Heun steps of 0.67 ms.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from plant.params import PlantParams
from plant.sim import Plant

DT = 0.67e-3
K_STEP, K_FAULT_ON, K_FAULT_OFF, K_END = 150, 450, 600, 900


def _single(mode: str) -> Plant:
    pp = PlantParams(topology="single", sc_connected=False)
    pp.grid.scr = 1000.0  # 1/SCR on 500 MVA: effectively an infinite bus for a 10 MW turbine
    # let the machine side motor (the ViSC absorbs ~0.3 p.u. after the fault) so that the DC chopper,
    # a kink the implicit reference solver cannot step across reliably, stays idle in both runs
    pp.turbine.p_me_min = -1.0
    # and draw on the rotor (a P=0 ViSC has ~0 aero power): keeps v_dc near 1 and the converter's DC
    # voltage limit idle; both limits are exercised by the fixed-step runs in test_plant_behaviour
    pp.turbine.p_headroom = 1.1
    p = Plant(pp, n_turbines=1, step_s=DT)
    if mode == "hd_visc":
        p.set_power_ref(0, p=0.0)
        p.reinitialise()
        p.set_mode(0, "hd_visc")
    return p


def _events(z_f: float = 0.0005):
    return {K_STEP: lambda q: q.set_grid_emf(0.95), K_FAULT_ON: lambda q: q.fault(True, z_f),
            K_FAULT_OFF: lambda q: q.fault(False)}


def _run_plant(p: Plant, z_f: float):
    ev = _events(z_f)
    ys = [p.state_real()]
    for k in range(K_END):
        if k in ev:
            ev[k](p)
        p.step()
        ys.append(p.state_real())
    return np.array(ys)


def _run_ivp(p: Plant, z_f: float, method: str = "Radau"):
    ev = _events(z_f)
    y = p.state_real()
    out = [y]
    marks = sorted(ev) + [K_END]
    k0 = 0
    for km in marks:
        t_eval = np.arange(k0 + 1, km + 1) * DT
        sol = solve_ivp(p.rhs_real, (k0 * DT, km * DT), y, method=method, t_eval=t_eval, rtol=1e-8, atol=1e-10,
                        max_step=2e-3)
        assert sol.success, sol.message
        out.extend(sol.y.T)
        y = sol.y[:, -1]
        p.set_state_real(y)
        if km in ev:
            ev[km](p)
        k0 = km
    return np.array(out)


def _compare(mode: str, z_f: float):
    ya = _run_plant(_single(mode), z_f)
    yb = _run_ivp(_single(mode), z_f)
    n = 1
    size = (ya.shape[1] - (ya.shape[1] - 2 * (9 * n + 12))) // 2
    i_a = ya[:, 0] + 1j * ya[:, size]
    i_b = yb[:, 0] + 1j * yb[:, size]
    w_a, w_b = ya[:, 4 * n], yb[:, 4 * n]  # v_dc^2
    e_i = np.sqrt(np.mean(np.abs(i_a - i_b) ** 2)) / np.sqrt(np.mean(np.abs(i_b) ** 2))
    e_w = np.sqrt(np.mean((w_a - w_b) ** 2)) / np.sqrt(np.mean(w_b**2))
    swing = np.max(np.abs(i_b)) - np.min(np.abs(i_b))
    print(f"\n{mode}: RMS error current {e_i:.2e}, v_dc^2 {e_w:.2e}; |i| swing {swing:.3f} p.u.")
    assert swing > 0.05, "the events must excite the dynamics"
    assert e_i < 0.01 and e_w < 0.01
    return e_i


def test_grid_following_matches_solve_ivp():
    _compare("grid_following", 0.0005)


@pytest.mark.slow
def test_hd_visc_matches_solve_ivp():
    # z_f = 0.002 p.u. (network base): V drops to ~0.89 p.u., the ViSC current rises to ~0.94 p.u.
    # without reaching the 1.5 p.u. limiter, whose switching (a discontinuous right-hand side)
    # stalls the implicit reference solver; the limited case is covered by test_plant_behaviour.
    _compare("hd_visc", 0.002)
