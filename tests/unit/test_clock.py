"""The one clock (sdvisc/clock.py): scaled readings, sleeps and deadlines, and two processes with
the same epoch agreeing. The clocks under test read and sleep through an injected wall clock
(:class:`FakeWall`), so nothing here depends on how fast or how busy the machine is."""

from __future__ import annotations

import pickle
import time

import pytest

from sdvisc.clock import Clock, ManualClock

EPOCH = 1_700_000_000.0


class FakeWall:
    """A wall clock for a :class:`Clock`: it moves when told (``advance``) or slept on."""

    def __init__(self, t: float = EPOCH) -> None:
        self.t = t
        self.slept: list[float] = []

    def time(self) -> float:
        return self.t

    def sleep(self, s: float) -> None:
        self.slept.append(s)
        self.t += s

    def advance(self, s: float) -> None:
        self.t += s


def clock_on(k: float, wall: FakeWall, epoch: float = EPOCH) -> Clock:
    return Clock(k, epoch, wall=wall.time, wall_sleep=wall.sleep)


def test_a_scaled_clock_runs_k_times_slower_from_its_epoch():
    wall = FakeWall()
    clock = clock_on(8.0, wall)
    assert clock.now() == EPOCH  # the virtual clock equals the wall clock at the epoch
    wall.advance(0.08)
    assert clock.now() - EPOCH == pytest.approx(0.01, abs=1e-6)
    wall.advance(8.0)
    assert clock.now() - EPOCH == pytest.approx(1.01, abs=1e-6)
    assert clock.to_wall(clock.now()) == pytest.approx(wall.t, abs=1e-6)
    assert clock.from_wall(EPOCH + 16.0) == pytest.approx(EPOCH + 2.0, abs=1e-6)
    assert clock_on(8.0, wall).now() == clock.now()  # another process, same epoch: the same reading
    assert wall.slept == []  # reading never sleeps


def test_sleeps_and_deadlines_are_in_simulated_seconds():
    wall = FakeWall()
    clock = clock_on(4.0, wall)
    clock.sleep(0.01)
    assert wall.slept == [pytest.approx(0.04)]
    deadline = clock.now() + 0.005
    assert clock.sleep_until(deadline) == pytest.approx(deadline, abs=1e-6)
    assert wall.slept == [pytest.approx(0.04), pytest.approx(0.02, abs=1e-6)]
    # a deadline already passed, or a sleep of nothing, does not sleep
    assert clock.sleep_until(deadline - 1.0) == pytest.approx(deadline, abs=1e-6)
    clock.sleep(0.0)
    clock.sleep(-1.0)
    assert len(wall.slept) == 2
    assert clock.wall_s(0.5) == 2.0


def test_real_time_is_the_wall_clock_and_slower_than_real_time_is_refused():
    default = Clock()
    assert default.wall is time.time and default.wall_sleep is time.sleep
    wall = FakeWall()
    assert clock_on(1.0, wall, epoch=123.0).now() == wall.t  # k = 1 reads the wall clock whatever the epoch
    with pytest.raises(ValueError):
        Clock(0.5)


def test_a_clock_is_its_scale_and_epoch_and_travels_to_another_process():
    wall = FakeWall()
    assert clock_on(4.0, wall) == Clock(4.0, EPOCH) and hash(clock_on(4.0, wall)) == hash(Clock(4.0, EPOCH))
    copy = pickle.loads(pickle.dumps(Clock(4.0, EPOCH)))
    assert copy == Clock(4.0, EPOCH) and copy.wall is time.time and copy.wall_sleep is time.sleep


def test_the_manual_clock_moves_only_when_told():
    c = ManualClock(10.0)
    assert c.now() == 10.0
    c.sleep(0.25)
    c.advance(1.0)
    assert c.now() == 11.25 and c.slept == [0.25]
    assert c.sleep_until(12.0) == 12.0 and c.sleep_until(11.0) == 12.0


@pytest.mark.parametrize("k", [8.0, 32.0])
def test_sdn_timers_take_the_same_simulated_time_decisions_at_any_time_scale(k):
    """The SDN app reads its clock for every packet and tick: a DR after an AK loss, with the SDC's
    heartbeats going on, is decided at the same simulated instants at k = 1 and at k."""
    from sdn_app.logic import Controller
    from sdn_app.timer import TICK_S
    from tests.unit.test_sdn_logic import make_config
    from tests.unit.test_sdn_resilience import ak, heartbeat, visc_on

    def decisions(time_scale: float) -> list:
        wall = FakeWall()
        clock = clock_on(time_scale, wall)
        ctl = Controller(make_config(backup_sdc=None), now=clock.now())
        # what arrives, in simulated seconds from the epoch: AKs every 10 ms (loss from 1.508 s),
        # heartbeats every 10 ms, ticks every TICK_S
        arrivals = [(1.0, "visc_on", None)]
        arrivals += [(0.5 + 0.010 * n + 0.0003, "heartbeat", n + 1) for n in range(150)]
        arrivals += [(1.1 + 0.010 * n + 0.0007, "ak", n + 1) for n in range(90)]
        arrivals += [(0.5 + TICK_S * n, "tick", None) for n in range(int(1.5 / TICK_S))]
        for t, kind, seq in sorted(arrivals, key=lambda a: a[0]):
            wall.t = clock.epoch + t * time_scale  # the wall time at which it happens
            now = clock.now()
            if kind == "visc_on":
                visc_on(ctl, now)
            elif kind == "heartbeat":
                heartbeat(ctl, "sdc1", seq, now)
            elif kind == "ak":
                t_sim = now - clock.epoch
                lost = 1.508 <= t_sim < 1.565  # control lost from 1.508 s until the new path carries it
                ak(ctl, seq, int(not lost), t_sim - 1.508 if lost else 0.0005, now)
            else:
                ctl.tick(now)
        return [{key: round(v - clock.epoch, 6) if key.startswith("t_") and isinstance(v, float) else v
                 for key, v in e.items()} for e in ctl.take_events()]

    real_time, scaled = decisions(1.0), decisions(k)
    (dr,) = [e for e in real_time if e["type"] == "dr"]
    assert dr["wt"] == "wt1_1" and dr["t_loss"] == pytest.approx(1.508, abs=0.001)
    # the hold (40 ms), confirmed by the next AK (every 10 ms here) at the next tick: simulated seconds
    assert 0.040 <= dr["t_detect"] - dr["t_loss"] <= 0.040 + 0.010 + TICK_S
    assert scaled == real_time
