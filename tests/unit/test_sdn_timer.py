"""The app's timer sleeps while no decision can be due (sdn_app.timer): pure SDN logic, injected
clock. Two promises: nothing is decided before :meth:`Controller.next_decision_at` unless a packet
arrives first, and a timer that follows :func:`sdn_app.timer.wait_s` takes the same decisions as
one ticking every 2 ms, within one tick, while waking far less often when nothing happens."""

from __future__ import annotations

import copy
import random

from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from sdn_app.logic import Controller
from sdn_app.timer import QUIET_TICK_S, TICK_S, wait_s
from tests.unit.test_sdn_liveness import _ak, _hb, _serving
from tests.unit.test_sdn_logic import make_config

END_S = 1.6
EDGE_S = 0.01  # s: five ticks; decisions nearer the window's end than this are not compared
DECISIONS = {"dr", "sdc_dead", "sdc_failover", "sdc_suspect", "dr_awaiting_sdc", "no_path", "failover_unavailable"}


def test_wait_is_one_tick_while_due_and_at_most_the_quiet_period_otherwise():
    assert wait_s(1.0, 1.0) == TICK_S and wait_s(1.0, 0.5) == TICK_S  # due now, or overdue
    assert abs(wait_s(1.0, 1.005) - 0.005) < 1e-12
    assert wait_s(1.0, float("inf")) == QUIET_TICK_S
    assert abs(wait_s(1.0, float("inf"), next_publish_at=1.003) - 0.003) < 1e-12


def _arrivals(fault: str, t_fault: float, seed: int) -> list[tuple]:
    """From 1.0 s (after :func:`_serving`): both SDCs beat every 10 ms, the turbine's AK every 10 ms,
    each delayed 0.2–3 ms. ``fault`` from ``t_fault``: ``path_reported`` (control lost, AK = 0 with
    its age, and the turbine's own report at the 40 ms hold), ``path_silent`` (the AKs stop too),
    ``sdc_kill`` (sdc1's heartbeats stop and the turbine reports its loss), or ``none``."""
    rng = random.Random(seed)
    out, ak_seq, hb_seq = [], 50, 100
    for n in range(int((END_S - 1.0) / 0.010)):
        t = 1.0 + 0.010 * n
        hb_seq += 1
        out.append((t + rng.uniform(0.0002, 0.003), "hb", "sdc2", hb_seq))
        if not (fault == "sdc_kill" and t >= t_fault):
            out.append((t + rng.uniform(0.0002, 0.003), "hb", "sdc1", hb_seq))
        lost = fault != "none" and t >= t_fault
        if fault == "path_silent" and lost:
            continue
        ak_seq += 1
        out.append((t + 0.005 + rng.uniform(0.0002, 0.003), "ak", ak_seq, int(not lost),
                    (t + 0.005 - t_fault) if lost else 0.0005, t + 0.005))
    if fault in ("path_reported", "sdc_kill"):  # the report the moment the loss lasted the hold
        out.append((t_fault + 0.040 + rng.uniform(0.0002, 0.003), "ak", 10_000, 0, 0.040, t_fault + 0.040))
    return sorted(out, key=lambda a: a[0])


def _run(arrivals: list[tuple], follow_wait: bool, check_bound: bool = False) -> tuple[list[dict], int]:
    """Feed the arrivals; tick every TICK_S, or as the app's timer does (``follow_wait``). Returns the
    decisions (events of :data:`DECISIONS`) and the number of ticks."""
    ctl = Controller(make_config(sdc_dead_s=0.030), now=0.0)
    _serving(ctl)
    ctl.take_events()
    events, ticks, i, now = [], 0, 0, 1.0
    while now < END_S:
        while i < len(arrivals) and arrivals[i][0] < now:
            a = arrivals[i]
            if a[1] == "hb":
                _hb(ctl, a[2], a[3], a[0])
            else:
                _ak(ctl, "wt1_1", a[2], a[3], a[4], a[0], sent=a[5])
            i += 1
        ctl.tick(now)
        ticks += 1
        next_at = ctl.next_decision_at(now)
        if check_bound and next_at > now + 1e-9:  # a tick just before the bound decides nothing
            probe = copy.deepcopy(ctl)
            probe.take_events()
            assert probe.tick(min(next_at, arrivals[i][0] if i < len(arrivals) else next_at) - 1e-6) == []
            assert not [e for e in probe.take_events() if e["type"] in DECISIONS]
        events += ctl.take_events()
        now = round(now + (wait_s(now, next_at) if follow_wait else TICK_S), 9)
    return [e for e in events if e["type"] in DECISIONS], ticks


def _latency(event: dict) -> float:
    """From a decision's cause (the loss, the last heartbeat, the silence's start) to the decision."""
    if "t_loss" in event:
        cause = event["t_loss"]
    elif "t_last_heartbeat" in event:
        cause = event["t_last_heartbeat"]
    else:
        cause = event["t_wall"] - event["silence_ms"] / 1e3
    return event["t_wall"] - cause


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@example(fault="path_silent", t_fault=1.1171875, seed=86)  # a decision at the window's end (see below)
@given(fault=st.sampled_from(["none", "path_reported", "path_silent", "sdc_kill"]),
       t_fault=st.floats(1.1, 1.3), seed=st.integers(0, 2**16))
def test_the_sleeping_timer_decides_what_the_2_ms_timer_decides_within_one_tick(fault, t_fault, seed):
    arrivals = _arrivals(fault, t_fault, seed)
    every_tick, n_every = _run(arrivals, follow_wait=False)
    sleeping, n_sleeping = _run(arrivals, follow_wait=True, check_bound=True)
    # the decisions of the 2 ms timer made well before the window's end; the sleeping timer's come up to a
    # tick later each (and a later one's cause with them), so near END_S one of them can fall past the
    # window: compared are the 2 ms timer's decisions before END_S - EDGE_S, in order, and the sleeping
    # timer may have no other decision before that (seen: path_silent, t_fault 1.1171875, seed 86 — the
    # third DR at 1.598 with the 2 ms timer, ≈ 1.6007 asleep, after END_S)
    inside = [e for e in every_tick if e["t_wall"] < END_S - EDGE_S]
    assert [e["type"] for e in sleeping[:len(inside)]] == [e["type"] for e in inside]
    assert all(e["t_wall"] >= END_S - 2 * EDGE_S for e in sleeping[len(inside):]), (inside, sleeping)
    if every_tick and inside:
        assert abs(every_tick[0]["t_wall"] - sleeping[0]["t_wall"]) <= TICK_S + 1e-9
    for a, b in zip(inside, sleeping):  # (a later decision's cause may itself have moved by a tick)
        assert abs(_latency(a) - _latency(b)) <= TICK_S + 1e-9, (a, b)
    if fault == "none":
        assert every_tick == [] and n_sleeping <= n_every / 3  # idle: ~100 wake-ups a second, not 500
    else:
        assert every_tick, "the fault was not detected at all"

