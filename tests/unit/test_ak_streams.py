"""Forged AK streams (issue 42 item 1): pure, injected clock. The app follows one AK stream per
turbine; a second stream alive beside it is a conflict, never acted on, and a real loss on the
followed stream is still a DR."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sdn_app.ak_streams import ACCEPTED, AkStreams
from sdn_app.dr import DrMonitor
from sdn_app.logic import Controller
from sdvisc import wire
from tests.unit.test_sdn_logic import frame, make_config
from tests.unit.test_sdn_resilience import heartbeat, visc_on

HOLD, PERIOD = 0.040, 0.010


def test_a_forged_jump_beside_the_genuine_stream_is_a_conflict_and_never_followed():
    """The issue's case: genuine AKs (seq 2400.., ctrl_rx 35000.. rising) every 10 ms; forged
    ones (seq 10**6 + n, ctrl_rx 0) every 2 ms. Before: two forged AKs took the stream over."""
    s = AkStreams(quiet_s=0.030)
    verdicts = {"genuine": [], "forged": []}
    conflicts = []
    for k in range(200):  # 0.4 s
        now = 1.0 + k * 0.002
        if k % 5 == 0:
            verdicts["genuine"].append(s.admit(2400 + k // 5, 35_000 + 15 * k, now))
        else:
            verdicts["forged"].append(s.admit(10**6 + k, 0, now))
        if (c := s.take_conflict()) is not None:
            conflicts.append((now, c))
    assert set(verdicts["genuine"]) == {"ok"}
    assert not set(verdicts["forged"]) & set(ACCEPTED)
    assert len(conflicts) == 1 and s.conflicts == 1  # once per episode
    assert conflicts[0][0] <= 1.012  # at the first genuine AK after two forged ones
    assert conflicts[0][1]["followed_seq"] in (2400, 2401) and conflicts[0][1]["other_seq"] >= 10**6


def test_ctrl_rx_going_back_is_another_stream():
    s = AkStreams()
    assert s.admit(10, 500, 1.00) == "ok"
    assert s.admit(11, 12, 1.01) == "candidate"  # the next seq, but fewer control packets than before
    assert s.admit(12, 13, 1.012) == "rejected"  # continued: a second stream beside the followed one
    assert s.admit(12, 510, 1.02) == "ok" and s.take_conflict() is not None


def test_a_restarted_turbine_is_followed_once_its_old_stream_stopped():
    s = AkStreams(quiet_s=0.030, stale_s=0.5)
    for k in range(5):
        assert s.admit(5000 + k, 9000 + k, 1.0 + k * PERIOD) == "ok"
    # the turbine restarts: counters from 0; followed once the old stream has been silent for stale_s
    assert s.admit(0, 0, 1.24) == "candidate"
    assert s.admit(1, 1, 1.25) == "rejected"  # 0.21 s of silence: not yet stopped
    assert s.admit(60, 60, 1.55) == "adopted"  # 0.51 s
    assert s.admit(61, 61, 1.56) == "ok" and s.conflicts == 0


def test_an_outage_longer_than_max_step_aks_is_followed_after():
    s = AkStreams(max_step=100, quiet_s=0.030)
    s.admit(10, 10, 1.0)
    assert s.admit(10 + 150, 10, 2.5) == "candidate"  # 1.5 s of lost AKs, then the same turbine again
    assert s.admit(10 + 151, 11, 2.51) == "adopted"


def test_a_forged_stream_is_followed_only_after_the_genuine_one_stopped_for_stale_s():
    """It ran beside the genuine stream: when the genuine AKs stop (a failure cut their path), it is
    not followed for stale_s (the DR by silence comes first, tests below); after that it is, until it
    stops in turn — then the genuine stream, back by then, is followed again."""
    s = AkStreams(quiet_s=0.030, stale_s=0.5)
    for k in range(10):
        s.admit(100 + k, 1000 + k, 1.0 + k * PERIOD)
        s.admit(10**6 + 2 * k, 0, 1.001 + k * PERIOD)
        s.admit(10**6 + 2 * k + 1, 0, 1.003 + k * PERIOD)
    forged = [s.admit(10**6 + 100 + k, 0, 1.1 + k * 0.002) for k in range(300)]  # 1.1 .. 1.7 s
    assert set(forged[:int(0.49 / 0.002)]) == {"rejected"} and "adopted" in forged
    assert s.current.seq >= 10**6
    assert s.admit(115, 1050, 1.75) == "rejected"  # the genuine stream back: not followed while the forged one runs
    for k in range(1, 30):
        s.admit(115 + k, 1050 + k, 1.75 + k * PERIOD)
    assert s.conflicts >= 2
    assert s.admit(10**6 + 400, 0, 1.80) == "ok"  # the forged stream's last AK
    verdicts = [s.admit(145 + k, 1080 + k, 2.05 + k * PERIOD) for k in range(30)]  # 0.25 .. 0.54 s after it
    assert "adopted" in verdicts and verdicts[-1] == "ok" and s.current.seq >= 145


def test_a_stream_followed_by_mistake_hands_over_once_it_stops():
    """Under load the genuine AKs paused 40 ms; a fuzzer's consistent AK stream began in the pause
    and (the genuine one silent for stale_s... here given) was followed. When it stops, the genuine
    stream is followed again (it was not: every AK of the turbine ignored, DR after DR)."""
    s = AkStreams(quiet_s=0.030, stale_s=0.5)
    s.admit(100, 1000, 1.0)
    assert s.admit(300, 300, 1.6) == "candidate" and s.admit(301, 301, 1.601) == "adopted"  # the mistake
    for k in range(1, 40):  # both alive: the genuine one is the conflict now
        s.admit(100 + k, 1000 + k, 1.6 + k * PERIOD)
        s.admit(301 + 2 * k, 301 + 2 * k, 1.605 + k * PERIOD)
    last_fuzz = 1.605 + 39 * PERIOD
    verdicts = [(t, s.admit(140 + k, 1040 + k, t)) for k, t in enumerate(last_fuzz + 0.005 + i * PERIOD
                                                                          for i in range(60))]
    adopted = [t for t, v in verdicts if v == "adopted"]
    assert adopted and adopted[0] - last_fuzz >= 0.5 and adopted[0] - last_fuzz < 0.5 + 2 * PERIOD
    assert verdicts[-1][1] == "ok"


def test_one_mutated_ctrl_rx_does_not_make_the_genuine_stream_another():
    """A fuzzer on the turbine's own host: one AK with the next seq and ctrl_rx = 2**31 - 1 is taken,
    but the genuine AKs after it still continue the stream (their ctrl_rx is compared with the lower
    of the last two)."""
    s = AkStreams()
    for k in range(5):
        s.admit(100 + k, 1000 + 15 * k, 1.0 + k * PERIOD)
    assert s.admit(105, 2**31 - 1, 1.045) == "ok"
    assert [s.admit(106 + k, 1075 + 15 * k, 1.05 + k * PERIOD) for k in range(5)] == ["ok"] * 5
    assert s.conflicts == 0


def test_a_reordered_genuine_ak_is_stale_not_a_conflict():
    s = AkStreams()
    for seq, now in ((1, 1.00), (2, 1.01), (4, 1.03), (3, 1.031), (5, 1.04), (2, 1.041), (6, 1.05)):
        s.admit(seq, seq * 10, now)
    assert s.conflicts == 0 and s.current.seq == 6


@settings(max_examples=200, deadline=None)
@given(forged=st.lists(st.tuples(st.integers(-2**31, 2**31 - 1), st.integers(0, 2**31 - 1),
                                 st.floats(0, 1)), max_size=60),
       start=st.integers(0, 10**6), rx0=st.integers(0, 10**6))
def test_whatever_is_forged_beside_it_the_genuine_stream_is_followed(forged, start, rx0):
    """Any forged AKs that do not continue the genuine stream (a counter more than 2 × max_step
    away, or ctrl_rx lower than the genuine one's) interleaved at any moments with a genuine stream
    every 10 ms: every genuine AK is used, no forged one ever is."""
    s = AkStreams(max_step=100, quiet_s=0.030)
    n = 60
    genuine = [(start + k, rx0 + 3 * k, 1.0 + k * PERIOD, "g") for k in range(n)]
    fakes = []
    for seq, rx, u in forged:
        t = 1.0 + u * n * PERIOD
        k = min(n - 1, int((t - 1.0) / PERIOD))
        if abs(seq - (start + k)) <= 200 and rx >= rx0 + 3 * max(0, k - 1):
            rx = max(0, rx0 + 3 * k - 1 - 300)  # make it not a continuation: fewer control packets than ever
            if rx >= rx0:
                continue
        fakes.append((seq, rx, t, "f"))
    for seq, rx, now, who in sorted(genuine + fakes, key=lambda m: (m[2], m[3] == "f")):
        verdict = s.admit(seq, rx, now)
        assert (verdict == "ok") if who == "g" else verdict not in ACCEPTED, (who, seq, rx, now, verdict)


# ---------------------------------------------------------------- the DR monitor and the app
def test_no_dr_on_the_forged_stream_and_a_real_loss_is_still_confirmed_within_hold_plus_one_period():
    m = DrMonitor(hold_s=HOLD, ak_timeout_s=0.030)
    m.start("wt1_1", now=0.0)
    seq, rx = 2400, 35_000
    now = 1.0
    while now < 2.0:  # genuine AK = 1 every 10 ms, forged AK = 0 (loss 80 ms) every 2 ms
        m.on_ak("wt1_1", seq, 1, rx, 0.0005, now=now)
        for j in range(1, 5):
            assert not m.on_ak("wt1_1", 10**6 + seq * 5 + j, 0, 0, 0.080, now=now + j * 0.002)
        assert m.due(["wt1_1"], now=now + 0.009) == []
        seq, rx, now = seq + 1, rx + 15, round(now + PERIOD, 6)
    assert m.tracks["wt1_1"].streams.conflicts == 1
    # a real failure at 2.0 cuts the control packets: the genuine AKs report it, forgeries go on
    t_fail, detected = now, None
    while detected is None and now < 2.2:
        m.on_ak("wt1_1", seq, 0, rx, now - t_fail, now=now)
        for j in range(1, 5):
            m.on_ak("wt1_1", 10**6 + seq * 5 + j, 1, 0, 0.0005, now=now + j * 0.002)  # forged "all well"
            if m.due(["wt1_1"], now=now + j * 0.002):
                detected = now + j * 0.002
        if detected is None and m.due(["wt1_1"], now=now):
            detected = now
        seq, now = seq + 1, round(now + PERIOD, 6)
    assert detected is not None and detected - t_fail <= HOLD + PERIOD + 1e-9


def test_a_real_loss_that_also_silences_the_genuine_aks_is_confirmed_despite_forged_ak_1():
    m = DrMonitor(hold_s=HOLD, ak_timeout_s=0.030)
    m.start("wt1_1", now=0.0)
    for k in range(50):
        m.on_ak("wt1_1", 100 + k, 1, 1000 + k, 0.0005, now=1.0 + k * PERIOD)
        m.on_ak("wt1_1", 10**6 + k, 1, 0, 0.0005, now=1.005 + k * PERIOD)
    last = 1.0 + 49 * PERIOD
    confirmed = [t for t in (last + i * 0.001 for i in range(1, 80)) if m.due(["wt1_1"], now=t)]
    assert confirmed and confirmed[0] - last <= HOLD + PERIOD


def _ak_frame(ctl, seq, value, ctrl_rx, age_s):
    wt = ctl.config.topology.hosts["wt1_1"].model_dump()  # the victim's own IP and MAC (L2 switch: same port)
    payload = wire.encode(wire.MsgType.AK, {"wt": 101, "seq": seq, "ak": value, "ctrl_rx": ctrl_rx,
                                            "ctrl_age_ms": age_s * 1e3}, header=wire.Header(seq, 0, 0))
    return frame(wt, payload)


def test_the_app_reports_the_conflict_once_and_does_not_reroute():
    ctl = Controller(make_config(backup_sdc=None), now=0.0)
    visc_on(ctl, 1.0)
    ctl.take_events()
    path = list(ctl.paths["wt1_1"].path)
    actions, now, hb = [], 1.5, 1
    for k in range(40):  # 0.4 s: genuine every 10 ms, forged AK = 0 every 2 ms in between
        actions += ctl.packet_in(3, 1, _ak_frame(ctl, 2400 + k, 1, 35_000 + 15 * k, 0.0005), now)
        for j in range(1, 5):
            actions += ctl.packet_in(3, 1, _ak_frame(ctl, 10**6 + 5 * k + j, 0, 0, 0.080), now + j * 0.002)
        heartbeat(ctl, "sdc1", hb, now)
        actions += ctl.tick(now + 0.009)
        now, hb = round(now + PERIOD, 6), hb + 1
    events = ctl.take_events()
    assert [e["type"] for e in events if e["type"] in ("dr", "ak_conflict")] == ["ak_conflict"]
    assert ctl.paths["wt1_1"].path == path and ctl.paths["wt1_1"].reroutes == 0
    assert ctl.counters["ak_conflict"] == 1 and ctl.counters["drop_ak_other_stream"] >= 150
    assert str(ctl.tables.t3["wt1_1"]) == "1/1"  # the forged AK = 0 never reached T3
    assert ctl.snapshot()["acks"]["wt1_1"]["ctrl_rx"] == 35_000 + 15 * 39


@pytest.mark.parametrize("quiet_s", [0, -1, 0.6])
def test_bad_parameters_are_refused(quiet_s):
    with pytest.raises(ValueError, match="quiet_s"):
        AkStreams(quiet_s=quiet_s, stale_s=0.5)
