"""Steady state of the 500 MW farm, power balance and the measurement interface (validation item 1)."""

import math

import numpy as np
import pytest

from plant.params import PlantParams
from plant.sim import Plant
from sdvisc.vocabulary import MEAS_FIELDS


@pytest.fixture(scope="module")
def settled():
    p = Plant(n_turbines=50)
    p.run_offline(0.3, record_every=10_000)
    return p


def test_power_balance_at_rated_wind(settled):
    p = settled
    o = p.outputs()
    kt = p.params.turbine.s_rated_mva / p.params.grid.s_base_mva
    ksc = p.params.condenser.s_rated_mva / p.params.grid.s_base_mva
    p_turb = np.sum(o["p_wt"]) * kt  # network base
    # independent accounting: power into the grid at the PCC + sum of R|I|^2 of every series branch
    # + power absorbed by the condenser (its own losses are not in the branch list)
    balance = o["p_grid"] + o["losses"] - o["p_sc"] * ksc
    err = abs(p_turb - balance) / p_turb
    print(f"\nturbines {p_turb * 500:.2f} MW, grid {o['p_grid'] * 500:.2f} MW, losses {o['losses'] * 500:.2f} MW,"
          f" SC {o['p_sc'] * 40:.4f} MW, mismatch {err:.2e}")
    assert err < 1e-3
    # rated wind: every machine side at 1 p.u.; the terminal has that less the filter's r_f |i|^2
    assert np.allclose(o["p_wt"] + p.params.turbine.rf * o["i_wt"] ** 2, 1.0, atol=1e-6), "rated wind: P_me = 1"
    assert 0.005 < o["losses"] / p_turb < 0.05


def test_state_is_stationary(settled):
    p = settled
    dX, _, _ = p._evaluate(p.X, p.xl)
    assert np.max(np.abs(dX)) < 1e-6
    o = p.outputs()
    assert 0.95 < o["v_pcc"] < 1.05 and abs(o["f_pcc_hz"] - 50.0) < 5e-5
    assert np.allclose(o["v_dc"], 1.0, atol=1e-6)
    assert np.all(o["pitch"] > 0.0), "above rated wind the pitch controller sheds power"


def test_measurement_dict(settled):
    m = settled.measurements()
    assert set(MEAS_FIELDS) <= set(m)
    for k in MEAS_FIELDS:
        assert m[k].shape == (50,) and np.all(np.isfinite(m[k]))
    s = (m["v_d"] + 1j * m["v_q"]) * np.conj(m["i_d"] + 1j * m["i_q"])
    assert np.allclose(s.real, m["p"]) and np.allclose(s.imag, m["q"])
    assert np.allclose(m["p"] + settled.params.turbine.rf * (m["i_d"] ** 2 + m["i_q"] ** 2), 1.0, atol=1e-6)


def test_outputs_keys(settled):
    o = settled.outputs()
    for k in ("t", "v_pcc", "f_pcc_hz", "p_wt", "q_wt", "i_wt", "p_sc", "q_sc", "sc_delta", "sc_e", "visc_delta",
              "visc_e", "v_dc", "pitch"):
        assert k in o


def test_recorded_is_outputs_without_the_full_node_solve(settled):
    """What timeseries.csv records (``recorded()``, no full node-voltage solve) against quantities
    computed independently: the PCC phase voltages of the full solve (balanced here: each is |V1|)
    and the measurement rows the SDC receives (tolerance: rounding)."""
    r, o, m = settled.recorded(), settled.outputs(), settled.measurements()
    assert set(r) == {"t", "v_pcc", "f_pcc_hz", "p", "q", "i_mag", "mode", "soc", "p_batt"}
    assert np.allclose(o["v_pcc_ph"], r["v_pcc"], rtol=1e-9, atol=0.0)
    assert np.allclose(r["p"], m["p"], rtol=1e-12, atol=1e-12) and np.allclose(r["q"], m["q"], rtol=1e-12, atol=1e-12)
    assert np.allclose(r["i_mag"], np.hypot(m["i_d"], m["i_q"]), rtol=1e-12, atol=0.0)
    for key, val in r.items():  # outputs() includes them, the same
        assert np.array_equal(o[key], val), key


def test_wind_below_rated_gives_mppt_power():
    pp = PlantParams(v_wind=9.0)
    p = Plant(pp, n_turbines=5)
    p.run_offline(0.2, record_every=10_000)
    o = p.outputs()
    expected = (9.0 / pp.turbine.v_wind_rated) ** 3
    assert np.allclose(o["p_wt"], expected, rtol=1e-2)
    assert np.allclose(o["pitch"], 0.0)


def test_remote_fallback_after_loss():
    p = Plant(n_turbines=5)
    p.set_mode([1, 2], "remote")
    m = p.measurements()
    v = m["v_d"] + 1j * m["v_q"]
    i = m["i_d"] + 1j * m["i_q"]
    vc = v + (p.params.turbine.rf + 1j * p.params.turbine.lf) * i
    n_ok = int(0.05 / p.step_s)
    for _ in range(n_ok):
        p.step(([1, 2], vc[[1, 2]].real, vc[[1, 2]].imag))
    assert (p.tb.mode[[1, 2]] == 2).all()
    # turbine 2 keeps receiving, turbine 1 loses its stream
    n_loss = int(0.12 / p.step_s)
    for _ in range(n_loss):
        p.step(([2], vc[[2]].real, vc[[2]].imag))
    assert p.tb.mode[1] == 0 and p.tb.fell_back[1], "turbine 1 must fall back to grid-following"
    assert p.tb.mode[2] == 2
    o = p.outputs()
    # its own P at the loss and Q* = 0 of its own: the reactive power is the plant controller's order
    assert abs(o["p_wt"][1] - 1.0) < 0.02 and abs(o["q_wt"][1] - p.tb.q_wpp[1]) < 0.02
    p.set_remote_fallback(False)
    p.set_mode(3, "remote")
    for _ in range(n_loss):
        p.step()
    assert p.tb.mode[3] == 2, "with the flag off the last reference is held"


def test_plug_and_replug():
    p = Plant(n_turbines=10)
    n0 = p.net.n_factorizations
    r = p.run_offline(1.2, events=[(0.2, lambda q: q.plug([0, 3], False)), (0.6, lambda q: q.plug([0, 3], True))],
                      record_every=15)
    t = r["t"]
    off = (t > 0.25) & (t < 0.55)
    assert np.all(r["p_wt"][off][:, [0, 3]] == 0.0) and np.all(r["i_wt"][off][:, [0, 3]] == 0.0)
    assert abs(r["p_wt"][-1, 0] - r["p_wt"][-1, 1]) < 1e-3 and abs(r["v_dc"][-1, 0] - 1.0) < 1e-3
    assert p.net.n_factorizations == n0 + 2


def test_remote_i_ref_option_and_service_call_signature():
    pp = PlantParams()
    pp.turbine.remote_apply = "i_ref"
    p = Plant(pp, n_turbines=5)
    p.set_mode(2, "remote")
    m = p.measurements()
    v = m["v_d"][2] + 1j * m["v_q"][2]
    i_ref = 0.5 * v / abs(v)  # 0.5 p.u. at unity power factor
    for _ in range(int(0.05 / p.step_s)):
        p.apply_remote([2], [0.0], [0.0], [i_ref.real], [i_ref.imag])
        p.step()
    o = p.outputs()
    assert abs(o["i_wt"][2] - 0.5) < 0.01 and abs(o["q_wt"][2]) < 0.03  # v angle moves as P drops
    assert p.fallbacks[2] == 0 and p.trips[2] == 0
    for _ in range(int(0.15 / p.step_s)):
        p.step()
    assert p.fallbacks[2] == 1 and p.tb.mode[2] == 0


def test_slow_term_hold_matches_per_step_evaluation():
    """Holding the slow mechanical terms over 10 steps (default) against evaluating them every step:
    a power-reference step makes the rotors accelerate and the pitch act."""
    res = []
    for every in (1, 10):
        p = Plant(n_turbines=5, slow_every=every)
        r = p.run_offline(1.5, events=[(0.1, lambda q: q.set_power_ref([0, 1], p=0.6))], record_every=15)
        res.append(r)
    a, b = res
    print(f"\npitch {a['pitch'][-1, 0]:.4f} vs {b['pitch'][-1, 0]:.4f} deg, omega_r {a['omega_r'][-1, 0]:.6f} vs"
          f" {b['omega_r'][-1, 0]:.6f}, max |dP| {np.max(np.abs(a['p_wt'] - b['p_wt'])):.2e}")
    assert a["pitch"][-1, 0] > a["pitch"][0, 0] + 1.0, "the pitch must act"
    assert np.max(np.abs(a["pitch"] - b["pitch"])) < 0.05
    assert np.max(np.abs(a["omega_r"] - b["omega_r"])) < 1e-3
    assert np.max(np.abs(a["p_wt"] - b["p_wt"])) < 1e-3


def test_apply_remote_holds_the_same_references_from_arrays_and_from_lists():
    """The plant service's call (intp index, float64 arrays: one compiled loop) and any other call
    (lists, scalars) hold the same references and the same reception step; a turbine index outside
    the plant is refused, not written."""
    fast, general = Plant(n_turbines=5), Plant(n_turbines=5)
    idx = np.array([1, 3], dtype=np.intp)
    v_d, v_q, i_d, i_q = np.array([1.01, 0.99]), np.array([0.1, -0.2]), np.array([0.5, 0.6]), np.array([0.0, 0.3])
    for p in (fast, general):
        p.set_mode(idx.tolist(), "remote")
        p.step()
    fast.apply_remote(idx, v_d, v_q, i_d, i_q)
    general.apply_remote(idx.tolist(), v_d.tolist(), v_q.tolist(), i_d.tolist(), i_q.tolist())
    for p in (fast, general):
        assert np.array_equal(p.tb.v_hold[idx], v_d + 1j * v_q) and np.array_equal(p.tb.i_hold[idx], i_d + 1j * i_q)
        assert np.array_equal(p.tb.last_rx_step[idx], [p.k, p.k])
    fast.apply_remote(idx, v_d, v_q)  # voltage references only: the current references stay
    assert np.array_equal(fast.tb.i_hold[idx], i_d + 1j * i_q)
    with pytest.raises(IndexError):
        fast.apply_remote(np.array([5], dtype=np.intp), v_d[:1], v_q[:1])


def test_remote_reference_loss_falls_back_exactly_at_the_stated_age():
    """Fall-back when the newest reference is ``remote_loss_fallback_s`` old, not a step earlier."""
    p = Plant(n_turbines=3)
    p.set_mode(1, "remote")
    m = p.measurements()
    v, i = m["v_d"][1] + 1j * m["v_q"][1], m["i_d"][1] + 1j * m["i_q"][1]
    vc = v + (p.params.turbine.rf + 1j * p.params.turbine.lf) * i
    p.apply_remote(np.array([1], dtype=np.intp), np.array([vc.real]), np.array([vc.imag]))
    k_rx = p.k
    loss_steps = math.ceil(p.params.turbine.remote_loss_fallback_s / p.step_s - 1e-9)
    while p.k < k_rx + loss_steps:
        assert p.tb.mode[1] == 2, f"fell back after {p.k - k_rx} steps, before {loss_steps}"
        p.step()
    p.step()  # the check runs at the start of a step
    assert p.tb.mode[1] == 0 and p.fallbacks[1] == 1
