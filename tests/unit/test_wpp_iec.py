"""The plant's Q/V controller after IEC 61400-27-1 (plant/wpp.py), with injected time: its own
cycle whatever the call rate, the measurement filter against its closed form, the communication
delay, the dip freeze with its hysteresis, the limits and the turbines' Q limitation."""

import math

import numpy as np
import pytest

from plant.params import WppParams
from plant.wpp import WppController, q_limit_at


def bare(**kw) -> WppParams:
    """Only the sampled integrator (no filter, lag, rate limit, delay), plus the changes ``kw``."""
    base = dict(t_ufilt_s=0.0, t_qfilt_s=0.0, t_xfv_s=0.0, dq_max_per_s=math.inf, comm_delay_s=0.0,
                droop=0.0, period_s=0.1)
    return WppParams(**{**base, **kw})


def run(c: WppController, dt: float, t_end: float, v) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(0.0, t_end + 1e-12, dt)
    return t, np.array([c.update(tk, v(tk)) for tk in t])


def test_the_controller_updates_at_its_own_period_whatever_the_call_rate():
    """Called every 0.67 ms or every 13 ms: one cycle per 0.1 s, the same orders at the cycles,
    constant between them (x += k_i e T_s, e = 0.01)."""
    ends = {}
    for dt in (0.00067, 0.013):
        c = WppController(bare())
        c.settle_at(0.0, 0.0, v_pcc=1.0)
        t, q = run(c, dt, 1.0, lambda _t: 0.99)
        assert c.samples == int(t[-1] / 0.1 + 1e-9) + 1
        k_cycle = np.floor(t / 0.1 + 1e-9)
        assert q == pytest.approx(10.0 * 0.01 * 0.1 * (k_cycle + 1), rel=1e-9)
        ends[dt] = q[-1]
    assert ends[0.00067] == pytest.approx(ends[0.013], rel=1e-12)


def test_voltage_filter_step_response_is_the_closed_form():
    """u_f after a step 1.0 -> 0.9 at t = 0: 0.9 + 0.1 exp(-t / T_WPufiltq), exact at any call rate."""
    tau = 0.05
    c = WppController(bare(t_ufilt_s=tau, u_dip=0.0))
    c.settle_at(0.0, 0.0, v_pcc=1.0)
    for tk in np.arange(0.0007, 0.3, 0.0007):
        c.update(tk, 0.9)
        assert c.u_f == pytest.approx(0.9 + 0.1 * math.exp(-tk / tau), abs=1e-12)


def test_the_order_reaches_the_turbines_after_the_communication_delay():
    c = WppController(bare(comm_delay_s=0.15))
    c.settle_at(0.0, 0.0, v_pcc=1.0)
    t, q = run(c, 0.001, 0.4, lambda _t: 0.99)
    assert np.all(q[t < 0.15 - 1e-9] == 0.0), "nothing arrives before the delay"
    assert q[np.searchsorted(t, 0.15)] == pytest.approx(10.0 * 0.01 * 0.1, rel=1e-9), "the first cycle's"
    assert c.q > c.q_turbines, "later cycles still in flight"


def test_dip_freezes_integrator_and_output_and_releases_with_hysteresis():
    """Below u_WPqdip = 0.8 everything is held; back at 0.85 (between the thresholds) still held;
    at 0.95 (>= u_release 0.9) the controller integrates again."""
    c = WppController(bare(u_dip=0.8, u_release=0.9))
    c.settle_at(0.0, 0.0, v_pcc=1.0)
    segments = ((0.0, 0.5, 0.99), (0.5, 1.0, 0.7), (1.0, 1.5, 0.85), (1.5, 2.0, 0.95))
    held = {}
    for t0, t1, v in segments:
        for tk in np.arange(t0, t1, 0.001):
            c.update(tk, v)
        held[v] = (c.frozen, c.x, c.q)
    assert not held[0.99][0] and held[0.7][0] and held[0.85][0] and not held[0.95][0]
    assert held[0.7][1:] == held[0.99][1:] and held[0.85][1:] == held[0.99][1:], "frozen: x and the order held"
    assert held[0.95][1] == pytest.approx(held[0.99][1] + 10.0 * 0.05 * 0.1 * 5, rel=1e-9), "5 cycles at e 0.05"


def test_absolute_and_rate_limits():
    """Rate limit: at most dX_refmax T_s per cycle; the order stops at q_max, the integrator with it."""
    c = WppController(bare(dq_max_per_s=0.5, k_i=100.0))
    c.settle_at(0.0, 0.0, v_pcc=1.0)
    t, q = run(c, 0.01, 3.0, lambda _t: 0.9)
    steps = np.diff(q[::10])
    assert np.max(steps) == pytest.approx(0.5 * 0.1, rel=1e-9)
    assert q[-1] == WppParams().q_max and c.x <= WppParams().q_max + 100.0 * 0.1 * 0.1


def test_turbine_q_limitation_over_terminal_voltage():
    p = WppParams()
    lim = q_limit_at(np.array([1.0, 1.05, 1.075, 1.1, 1.2]), p)
    assert lim == pytest.approx([p.q_max, p.q_max, 0.5 * p.q_max, 0.0, 0.0], abs=1e-12)
    c = WppController(bare())
    c.settle_at(0.3, 0.0, v_pcc=1.0)
    q = c.update(0.0, 1.0, np.array([1.0, 1.09]))
    assert q == pytest.approx([0.3, 0.2 * p.q_max], abs=1e-12)
    assert c.q_applied == pytest.approx(np.mean(q))


def test_reactive_power_mode_goes_to_its_reference():
    c = WppController(bare(mode="reactive_power", q_ref=0.2, k_i_q=2.0))
    c.settle_at(0.0, 0.0, v_pcc=1.0)
    run(c, 0.01, 10.0, lambda _t: 1.0)
    assert c.q_turbines == pytest.approx(0.2, abs=1e-6)


def test_sampled_loop_poles_against_the_closed_form():
    """Integral only, no lag, the order seen two cycles late (T_comm = T_s): x_k = x_{k-1} - K_i T_s k
    x_{k-2}, i.e. z^2 - z + K_i T_s k = 0: complex poles of modulus sqrt(K_i T_s k), on the unit circle
    at K_i T_s k = 1 (60 degrees per cycle: 1/(6 T_s) Hz); with T_comm = 0 it is z = 1 - K_i T_s k."""
    from report.f7_mechanism import wpp_loop_poles

    for k in (0.5, 1.0, 1.3):
        z = wpp_loop_poles(bare(t_xfv_s=0.0, comm_delay_s=0.1, k_i=10.0), k)
        assert np.max(np.abs(z)) == pytest.approx(math.sqrt(10.0 * 0.1 * k), rel=1e-9)  # complex: K_i T_s k > 1/4
    z = wpp_loop_poles(bare(t_xfv_s=0.0, comm_delay_s=0.1, k_i=10.0), 1.0)
    assert np.max(np.abs(np.angle(z))) == pytest.approx(math.pi / 3, rel=1e-9)
    z = wpp_loop_poles(bare(t_xfv_s=0.0, comm_delay_s=0.0, k_i=10.0), 0.5)
    assert np.max(np.abs(z)) == pytest.approx(1.0 - 10.0 * 0.1 * 0.5, rel=1e-9)
