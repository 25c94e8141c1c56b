"""The grid-following turbines' fault ride-through, the plant's PCC voltage controller and the
onshore comparison unit (issue 28), against closed forms and linearisation."""

import numpy as np
import pytest

from plant import turbine_laws as laws
from plant.cases import COMPARISON_UNIT, comparison_visc_plant, sc_plant
from plant.linearise import jacobian
from plant.params import PlantParams, WppParams
from plant.sim import Plant
from plant.wpp import WppController, legacy_params
from sdvisc.vocabulary import OMEGA0


def test_frt_reactive_current_and_priority_closed_form():
    """Below 0.9 p.u. the reference gains k (0.9 - V_d) of capacitive current with Q priority; at or
    above it, or with k = 0, it is exactly the circular-limited (P* - jQ*)/V_d."""
    i_max, v_dip, k = 1.1, 0.9, 2.0
    # V_d 0.6: Delta i_q = -2 * 0.3 = -0.6, i_d = min(1/0.6, sqrt(1.21 - 0.36))
    i_d, i_q = laws.gfl_current_ref(1.0, 0.0, 0.6, i_max, v_dip, k)
    assert i_q == pytest.approx(-0.6, abs=1e-15)
    assert i_d == pytest.approx(np.sqrt(i_max**2 - 0.36), abs=1e-15)
    # a deep dip: the reactive current takes the whole limit, no active current left
    i_d, i_q = laws.gfl_current_ref(1.0, 0.0, 0.2, i_max, v_dip, k)
    assert (i_d, i_q) == (pytest.approx(0.0, abs=1e-12), pytest.approx(-i_max, abs=1e-15))
    # normal operation and k = 0: the former law bit for bit
    for vd, kk in ((0.95, k), (0.6, 0.0)):
        i_d, i_q = laws.gfl_current_ref(1.0, -0.2, vd, i_max, v_dip, kk)
        d0, q0 = 1.0 / max(vd, 0.3), -0.2 / max(vd, 0.3)
        scale = min(1.0, i_max / np.hypot(d0, q0))
        assert (i_d, i_q) == (d0 * scale, q0 * scale)


def test_legacy_wpp_controller_integrates_at_every_call_and_limits():
    """The controller before issue 39 (legacy_params): x grows by k_i e h at every call, the order
    stops at q_max."""
    wp = legacy_params(WppParams(k_i=10.0, droop=0.0, q_max=0.33))
    c = WppController(wp)
    c.update(0.0, 0.99)
    for k in range(1, 4):
        q = c.update(0.01 * k, 0.99)  # e = 0.01 held
        assert q == pytest.approx(10.0 * 0.01 * 0.01 * k, rel=1e-12)
    for k in range(4, 1000):
        q = c.update(0.01 * k, 0.9)
    assert q == wp.q_max and c.x == pytest.approx(wp.q_max, abs=0.02), "clipped, integrator stopped"


def test_farm_starts_in_the_plant_controllers_steady_state():
    """The initial state meets V_pcc = v_ref - droop Q* and stays there (no event, 1 s)."""
    p = Plant(PlantParams())
    wp = p.params.wpp
    q = p.tb.q_wpp[0]
    v0 = p.outputs()["v_pcc"]
    assert abs(q) < wp.q_max and v0 == pytest.approx(wp.v_ref - wp.droop * q, abs=1e-9)
    r = p.run_offline(1.0, record_every=50)
    assert np.max(np.abs(r["v_pcc"] - v0)) < 1e-5 and np.max(np.abs(r["q_wt"][:, 0] - r["q_wt"][0, 0])) < 1e-4


def test_reactive_power_mode_starts_at_its_reference_and_holds_it():
    """IEC reactive-power mode (Q* = q_ref): the farm starts at q_ref, not at the voltage mode's droop
    order, and stays there without an event (the voltage mode's k_i 10 made this loop oscillate at
    ≈ 0.6 Hz through the 0.3 s of cycle, lag and delay); after a grid EMF step it returns to q_ref."""
    pp = PlantParams()
    pp.wpp = WppParams(mode="reactive_power", q_ref=0.05)
    p = Plant(pp)
    assert p.tb.q_wpp[0] == pytest.approx(0.05, abs=1e-12)
    r = p.run_offline(3.0, record_every=50)
    assert np.ptp(r["v_pcc"]) < 1e-5
    pp2 = PlantParams()
    pp2.wpp = WppParams(mode="reactive_power", q_ref=0.0)
    p2 = Plant(pp2)
    r2 = p2.run_offline(8.0, events=[(0.5, lambda q: q.set_grid_emf(q.params.grid.e_grid * 0.97))], record_every=50)
    late = r2["t"] > 6.0
    assert np.max(np.abs(r2["q_wt"][late, 0])) < 0.01  # back at its reference, no oscillation left
    assert np.ptp(r2["v_pcc"][late]) < 1e-3


def test_wpp_raises_the_pcc_after_a_grid_voltage_drop():
    """Grid EMF -0.05: with the controller (its turbine Q limitation off) the PCC returns to within
    droop x Q of its reference; without the controller it stays down by about the drop; with the Q
    limitation the turbines stop short of it, their terminals on the limitation's line below 1.1."""
    out = {}
    for case in ("no Q limitation", "off", "default"):
        pp = PlantParams()
        pp.wpp.enabled = case != "off"
        if case == "no Q limitation":
            pp.wpp.u_qlim_knee = pp.wpp.u_qlim_zero = float("inf")
        p = Plant(pp)
        e0 = p.params.grid.e_grid
        r = p.run_offline(4.0, events=[(0.5, lambda q, e0=e0: q.set_grid_emf(e0 - 0.05))], record_every=20)
        out[case] = (r["v_pcc"][0], r["v_pcc"][-1], r["q_wt"][-1, 0], float(np.max(r["v_wt"][-1])))
    (v0, v1, q1, _), (u0, u1, _, _) = out["no Q limitation"], out["off"]
    assert v1 == pytest.approx(1.0 - 0.04 * q1, abs=2e-3), "back on the droop line"
    assert u0 - u1 > 0.04 and v0 - v1 < 0.5 * (u0 - u1)
    _, w1, q_lim, v_wt = out["default"]
    wp = PlantParams().wpp
    assert u1 < w1 < v1 and v_wt < wp.u_qlim_zero
    assert q_lim == pytest.approx(wp.q_max * (wp.u_qlim_zero - v_wt) / (wp.u_qlim_zero - wp.u_qlim_knee), abs=0.01)


def test_onshore_unit_sits_behind_its_transformers_at_the_pcc():
    """The 40 MVA unit: V_t - V_pcc = Z i with Z = x_ttr on 4 x 11 MVA + x_step-up on 40 MVA."""
    p = comparison_visc_plant()
    p.set_visc_params(p.visc_params.with_changes(v_ref=1.04))
    p.run_offline(2.0, record_every=100)
    net, pp = p.net, p.params
    z = net.z_onshore_unit() * net.k_t[COMPARISON_UNIT]  # on the unit's base
    z_closed = (complex(pp.grid.r_ttr, pp.grid.x_ttr) * 40.0 / (4 * pp.grid.s_ttr_mva) + 1j * pp.x_onshore_step_up)
    assert z == pytest.approx(z_closed, rel=1e-12)
    _, _, aux = p._eval_cached()
    v_t, i_t = aux["v"][COMPARISON_UNIT], aux["i"][COMPARISON_UNIT]
    v_pcc = net.solve(net.injections(aux["i"], aux["e_grid"], aux["e_sc"], aux["i_load"]))[net.pcc]
    cf = 1j * pp.turbine.cf * v_t  # the filter capacitor's current stays at the terminal
    assert v_t - v_pcc == pytest.approx(z * (i_t - cf), abs=1e-9)


def test_f3_terminal_rises_reproduce_the_paper():
    """F3 (a), pinned: V* / AVR reference +0.04 at 1 s; both terminals rise by the paper's
    1.00 -> 1.035 within 10 % (docs/report.md, Which voltage)."""
    p = sc_plant()
    cp = p.params.condenser
    ref0 = p.sc.v_ref
    r = p.run_offline(6.0, events=[(1.0, lambda q: q.set_avr_ref(ref0 + 0.04))], record_every=20)
    rise_sc = r["v_sc"][-1] - r["v_sc"][r["t"] < 1.0][-1]
    p = comparison_visc_plant()
    vp = p.visc_params
    r = p.run_offline(3.0, events=[(1.0, lambda q: q.set_visc_params(vp.with_changes(v_ref=1.04)))],
                      record_every=20)
    v_t = r["v_wt"][:, COMPARISON_UNIT]
    rise_v = v_t[-1] - v_t[r["t"] < 1.0][-1]
    print(f"\nF3 terminal rise: SC {rise_sc:.4f}, SDViSC {rise_v:.4f} p.u. (paper 0.035)")
    assert rise_v == pytest.approx(0.035, rel=0.10)
    # the SC ends at 0.0324 with its 0.12 step-up (0.0313 with 0.10, -10.5 %): its proportional exciter
    # (SEXS K 200) keeps E_fd/K below the reference and its droop takes 0.02 x Q (docs/plant.md,
    # Synchronous condenser); the ideal regulator's 0.04 x_tr / (x_tr + m_q) = 0.0343 bounds it
    assert rise_sc == pytest.approx(0.035, rel=0.10)
    assert rise_sc < 0.04 * cp.x_tr / (cp.x_tr + cp.m_q)


def test_pll_and_current_loop_eigenvalues_against_the_small_signal_model():
    """One grid-following turbine on a stiff bus (SCR 1000, the SC out): the Jacobian of the plant's
    right-hand side (central differences) has the closed-form poles of the inner current loop,
    s^2 + omega0 (k_pc + r_f)/l_f s + omega0 k_ic/l_f = 0 (filter l_f, r_f with the PI and the
    cross-coupling cancelled), and of the PLL, s^2 + omega0 k_p s + omega0 k_i = 0, within 3 %."""
    pp = PlantParams(topology="single", sc_connected=False)
    pp.grid.scr = 1000.0
    p = Plant(pp, n_turbines=1, slow_every=1, jit=False)
    eig = np.linalg.eigvals(jacobian(p, p.state_real(), rel_step=1e-7))
    tp = pp.turbine
    # current loop: (l_f/w0) s i = k_pc e + k_ic xi - r_f i  ->  s^2 + w0 (k_pc + r_f)/l_f s + w0 k_ic/l_f = 0
    current = np.roots([1.0, OMEGA0 * (tp.kpc + tp.rf) / tp.lf, OMEGA0 * tp.kic / tp.lf])
    pll = np.roots([1.0, OMEGA0 * tp.kp_pll, OMEGA0 * tp.ki_pll])
    for pole in (*current, *pll):
        nearest = eig[np.argmin(np.abs(eig - pole))]
        assert abs(nearest - pole) <= 0.03 * abs(pole), f"pole {pole:.4g}: nearest eigenvalue {nearest:.4g}"
