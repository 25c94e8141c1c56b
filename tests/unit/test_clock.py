"""The one clock (sdvisc/clock.py): scaled readings, sleeps and deadlines, and two processes with
the same epoch agreeing. Only lower bounds on real sleeps are asserted (a busy machine may sleep
longer, never shorter)."""

from __future__ import annotations

import time

import pytest

from sdvisc.clock import Clock, ManualClock


def test_a_scaled_clock_runs_k_times_slower_from_its_epoch():
    epoch = time.time()
    k = 8.0
    clock = Clock(k, epoch)
    w0, v0 = time.time(), clock.now()
    time.sleep(0.08)
    w1, v1 = time.time(), clock.now()
    assert v1 - v0 == pytest.approx((w1 - w0) / k, abs=2e-3)
    assert clock.to_wall(clock.now()) == pytest.approx(time.time(), abs=2e-3)
    assert Clock(k, epoch).now() == pytest.approx(clock.now(), abs=2e-3)  # another process, same epoch


def test_sleeps_and_deadlines_are_in_simulated_seconds():
    clock = Clock(4.0, time.time())
    w0 = time.time()
    clock.sleep(0.01)
    assert time.time() - w0 >= 0.04
    deadline = clock.now() + 0.005
    assert clock.sleep_until(deadline) >= deadline - 1e-6
    assert time.time() - w0 >= 0.04 + 0.02 - 1e-3
    assert clock.wall_s(0.5) == 2.0


def test_real_time_is_the_wall_clock_and_slower_than_real_time_is_refused():
    assert Clock().now() == pytest.approx(time.time(), abs=1e-3)
    with pytest.raises(ValueError):
        Clock(0.5)


def test_the_manual_clock_moves_only_when_told():
    c = ManualClock(10.0)
    assert c.now() == 10.0
    c.sleep(0.25)
    c.advance(1.0)
    assert c.now() == 11.25 and c.slept == [0.25]
    assert c.sleep_until(12.0) == 12.0 and c.sleep_until(11.0) == 12.0
