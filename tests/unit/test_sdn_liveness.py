"""Liveness that is a detector, partitions reported once and healed, and one bad message never
stopping the app: pure SDN logic with an injected clock."""

from __future__ import annotations

import random

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sdn_app import flows as fl
from sdn_app.liveness import ALIVE_AFTER, SdcLiveness
from sdn_app.logic import Controller
from sdvisc import wire
from sdvisc.config import AppConfig
from tests.unit.test_sdn_logic import decode_out, frame, ingress, is_learn, make_config, request
from topologies import topos
from topologies.base import describe

TICK = 0.002


# ---------------------------------------------------------------------------- the detector alone
def test_steady_heartbeats_make_a_quick_detector():
    live = SdcLiveness(period_s=0.010, sdc_dead_s=0.030)
    for k in range(50):
        live.on_heartbeat("sdc1", k + 1, 1.0 + 0.010 * k)
    last = 1.0 + 0.49
    assert not live.suspected("sdc1", last + 0.012) and live.suspected("sdc1", last + 0.020)
    assert not live.silent("sdc1", last + 0.029) and live.silent("sdc1", last + 0.031)


def test_jittery_heartbeats_widen_the_timeout_instead_of_crying_wolf():
    rng = random.Random(1)
    live = SdcLiveness(period_s=0.010, sdc_dead_s=0.030)
    t, seq = 1.0, 0
    for _ in range(200):  # arrivals delayed by a busy switch: bursts and gaps of up to ~40 ms
        t += rng.choice([0.001, 0.002, 0.010, 0.010, 0.010, 0.020, 0.035, 0.040])
        seq += 1
        live.on_heartbeat("sdc1", seq, t)
    assert not live.silent("sdc1", t + 0.045)  # a gap this network shows now and then
    assert live.silent("sdc1", t + 0.150)  # many heartbeats missing: a death candidate


def test_a_dead_sdc_comes_back_only_after_several_heartbeats_and_a_restart_is_noticed():
    live = SdcLiveness()
    for k in range(1, 20):
        live.on_heartbeat("sdc1", k, 0.01 * k)
    live.declare_dead("sdc1")
    changes = [live.on_heartbeat("sdc1", 19 + k, 1.0 + 0.01 * k) for k in range(1, ALIVE_AFTER + 1)]
    assert changes[:-1] == [[]] * (ALIVE_AFTER - 1) and changes[-1] == ["alive"] and "sdc1" not in live.dead
    assert live.on_heartbeat("sdc1", 1, 2.0) == []  # one heartbeat going back may be forged
    assert live.on_heartbeat("sdc1", 2, 2.01) == ["restarted"]  # a second one confirms the restart
    assert live.on_heartbeat("sdc1", 2**31 - 1, 2.02) == [] and live.tracks["sdc1"].seq == 2
    assert live.on_heartbeat("sdc1", 3, 2.03) == []  and live.tracks["sdc1"].seq == 3


# ---------------------------------------------------------------------------- the controller
def _hb(ctl, sdc, seq, now):
    h = ctl.config.topology.hosts[sdc].model_dump()
    payload = wire.encode(wire.MsgType.HEARTBEAT, {"sdc_id": int(sdc[-1]), "seq": seq, "n_instances": 1,
                                                   "t_wall": 0.0}, header=wire.Header(seq, 0, 0))
    return ctl.packet_in(*ingress(ctl, sdc), frame(h, payload), now)


def _ak(ctl, wt, seq, value, age_s, now, sent=None, where=None):
    h = ctl.config.topology.hosts[wt].model_dump()
    sent = now if sent is None else sent
    payload = wire.encode(wire.MsgType.AK, {"wt": wire.turbine_id(*wire.parse_turbine(wt)), "seq": seq, "ak": value,
                                            "ctrl_rx": seq, "ctrl_age_ms": age_s * 1e3},
                          header=wire.Header(seq, int(sent), int((sent % 1) * 1e9)))
    return ctl.packet_in(*(where or (3, 1)), frame(h, payload), now)


def _visc_on(ctl, wt="wt1_1", now=1.0):
    o = ctl.config.topology.hosts["owfcc"].model_dump()
    return ctl.packet_in(*ingress(ctl, "owfcc"), frame(o, request(wire.Command.VISC_ON, wt=wt)), now)


@pytest.mark.parametrize("seed", range(5))
def test_no_false_death_or_dr_when_the_network_only_delays(seed):
    """Fault-free, 20 s: every packet-in (heartbeats of both SDCs, the turbine's AKs) is delayed by
    a queue that now and then stalls for up to 60 ms, and control packets reach the turbine with
    gaps of up to 30 ms (so it reports AK = 0 at times). Nothing failed: no SDC may be declared
    dead, no failover, no DR."""
    rng = random.Random(seed)
    ctl = Controller(make_config(sdc_dead_s=0.030), now=0.0)
    arrivals = []  # (arrival time, kind, ...)
    stall_until = 0.0
    t = 0.5
    ak_seq, last_ctrl, next_ctrl = 0, 1.1, 1.1
    while t < 20.0:
        if rng.random() < 0.01:  # a stall of the switches' main thread: everything queued behind it
            stall_until = max(stall_until, t + rng.uniform(0.005, 0.060))
        deliver = max(t, stall_until) + rng.uniform(0.0003, 0.003)
        k = int(round(t / 0.010))
        arrivals.append((deliver, "hb", "sdc1", k))
        arrivals.append((deliver + rng.uniform(0, 0.002), "hb", "sdc2", k))
        if t > 1.1:  # the turbine's control packets: every Ts, with a gap of 10-30 ms now and then
            while next_ctrl <= t:
                last_ctrl = next_ctrl
                next_ctrl += rng.uniform(0.010, 0.030) if rng.random() < 0.004 else 0.00067
            ak_seq += 1
            age = t - last_ctrl
            arrivals.append((deliver, "ak", int(age <= 0.010), age, t, ak_seq))
        t += 0.010
    arrivals.sort(key=lambda a: a[0])
    now, i = 0.5, 0
    events = []
    while now < 20.1:
        while i < len(arrivals) and arrivals[i][0] <= now:
            a = arrivals[i]
            if a[1] == "hb":
                _hb(ctl, a[2], a[3] + 1, a[0])
            else:
                _ak(ctl, "wt1_1", a[5], a[2], a[3], a[0], sent=a[4])
            i += 1
        if abs(now - 1.0) < TICK / 2:
            _visc_on(ctl, now=now)
        ctl.tick(now)
        events += [e["type"] for e in ctl.take_events()]
        now = round(now + TICK, 6)
    for kind in ("sdc_dead", "sdc_failover", "dr", "dr_not_acted", "no_path"):
        assert kind not in events, (kind, events.count(kind))


def test_a_killed_sdc_is_still_detected_and_failed_over_quickly():
    ctl = Controller(make_config(sdc_dead_s=0.030), now=0.0)
    _serving(ctl, acks=False)
    t_kill = 1.0  # sdc1's last heartbeat was at 0.99; the turbine's last control packet at 1.0
    detected = None
    for step in range(1, 100):
        now = round(t_kill + step * TICK, 6)
        if step % 5 == 0:
            _hb(ctl, "sdc2", 100 + step, now)
            _ak(ctl, "wt1_1", step, int(now - t_kill < 0.010), now - t_kill, now)
        ctl.tick(now)
        if any(e["type"] == "sdc_failover" for e in ctl.take_events()):
            detected = now
            break
    assert detected is not None and detected - t_kill <= 0.045 and ctl.active_sdc == "sdc2"


def _serving(ctl, acks: bool = True) -> None:
    """Both SDCs beating every 10 ms until 0.99 s, wt1_1 in ViSC from 0.5 s, its AKs fine until 0.99 s."""
    for k in range(1, 100):
        _hb(ctl, "sdc1", k, 0.01 * k)
        _hb(ctl, "sdc2", k, 0.01 * k + 0.001)
    _visc_on(ctl, now=0.5)
    for k in range(1, 50) if acks else ():
        _ak(ctl, "wt1_1", k, 1, 0.0, 0.5 + 0.01 * k)


def _kill_with_late_heartbeats(ctl, last_hb: float, until: float, sdc1_resumes: float | None = None,
                               sdc2_pauses: tuple[float, float] | None = None) -> list[dict]:
    """From 1.0 s the turbine receives no control packets (its AK = 0 every 10 ms, then its report at
    the hold); sdc1's heartbeats stop after ``last_hb`` (or pause until ``sdc1_resumes``); sdc2's go
    on (but for ``sdc2_pauses``)."""
    _serving(ctl)
    ctl.take_events()
    t_loss, events, seq1 = 1.0, [], 100
    for step in range(1, int((until - t_loss) / TICK)):
        now = round(t_loss + step * TICK, 6)
        if step % 5 == 0:
            if sdc2_pauses is None or not sdc2_pauses[0] < now < sdc2_pauses[1]:
                _hb(ctl, "sdc2", 100 + step, now + 0.001)
            if now <= last_hb or (sdc1_resumes is not None and now >= sdc1_resumes):
                seq1 += 1
                _hb(ctl, "sdc1", seq1, now + 0.0005)
            _ak(ctl, "wt1_1", 50 + step, 0, now - t_loss, now)
        ctl.tick(now)
        events += ctl.take_events()
    return events


def test_a_loss_while_the_sdcs_heartbeats_are_overdue_waits_for_its_verdict_and_fails_over():
    # seen at time scale 1: the killed SDC's heartbeat thread ran on for 13 ms after its control
    # stopped; the turbine's report at the 40 ms hold came while the SDC was overdue but not yet
    # silent, and the app rerouted to the dead SDC first (failover 100-190 ms after the kill)
    ctl = Controller(make_config(sdc_dead_s=0.030), now=0.0)
    events = _kill_with_late_heartbeats(ctl, last_hb=1.013, until=1.1)  # (the backup's control is not modelled)
    kinds = [e["type"] for e in events]
    assert "dr" not in kinds and kinds.count("dr_awaiting_sdc") == 1 and ctl.active_sdc == "sdc2"
    failover = next(e for e in events if e["type"] == "sdc_failover")
    assert failover["t_wall"] - 1.0 <= 0.040 + 0.030  # within the hold and sdc_dead_s of the loss


def test_a_late_heartbeat_lets_the_waiting_dr_go_ahead():
    # the path failed while sdc1's heartbeats were late; sdc1 lives: the DR goes ahead, no failover
    ctl = Controller(make_config(sdc_dead_s=0.030), now=0.0)
    events = _kill_with_late_heartbeats(ctl, last_hb=1.013, until=1.2, sdc1_resumes=1.035)
    kinds = [e["type"] for e in events]
    assert "sdc_failover" not in kinds and "sdc_dead" not in kinds and ctl.active_sdc == "sdc1"
    dr = next(e for e in events if e["type"] == "dr")
    assert 1.040 <= dr["t_wall"] <= 1.040 + 0.030


def test_a_kill_under_load_still_waits_though_the_backups_heartbeats_are_late_too():
    # seen at k = 1 with 130 late plant steps: the backup's heartbeats were overdue as well when the
    # killed SDC's loss reached the hold; the killed one's silence is still much the longer
    ctl = Controller(make_config(sdc_dead_s=0.030), now=0.0)
    events = _kill_with_late_heartbeats(ctl, last_hb=1.0, until=1.1, sdc2_pauses=(1.02, 1.045))
    kinds = [e["type"] for e in events]
    assert "dr" not in kinds and "dr_awaiting_sdc" in kinds and ctl.active_sdc == "sdc2"


def test_after_a_failover_the_l2_switch_learns_the_address_the_turbine_sends_to():
    # the turbine keeps addressing the primary (sdc1); the backup's switch rewrites. The learning
    # frames of the failover path must teach the L2 switch sdc1's MAC on the path's uplink (they
    # taught sdc2's: after a DR had moved sdc1's MAC to the other uplink, MEAS went nowhere)
    from os_ken.lib.packet import ethernet, packet

    ctl = Controller(make_config(sdc_dead_s=0.030), now=0.0)
    _serving(ctl)
    actions = []
    for step in range(1, 50):
        now = round(1.0 + step * TICK, 6)
        if step % 5 == 0:
            _hb(ctl, "sdc2", 100 + step, now + 0.001)
            actions += _ak(ctl, "wt1_1", 50 + step, 0, now - 1.0, now)
        actions += ctl.tick(now)
        if ctl.active_sdc == "sdc2":
            break
    assert ctl.active_sdc == "sdc2"
    learned = {packet.Packet(a.data).get_protocol(ethernet.ethernet).src
               for a in actions if isinstance(a, fl.PacketOut) and is_learn(a)}
    hosts = ctl.config.topology.hosts
    assert hosts["sdc1"].mac in learned and hosts["sdc2"].mac not in learned


def test_when_every_sdc_is_overdue_at_once_the_dr_does_not_wait():
    # a stall of the switches delays every heartbeat alike (seen when a failed link came back): the
    # turbine's loss is the path's, its DR goes ahead at the hold
    ctl = Controller(make_config(sdc_dead_s=0.030), now=0.0)
    events = _kill_with_late_heartbeats(ctl, last_hb=1.013, until=1.1, sdc1_resumes=1.06, sdc2_pauses=(1.013, 1.06))
    kinds = [e["type"] for e in events]
    assert "dr_awaiting_sdc" not in kinds and "sdc_failover" not in kinds
    dr = next(e for e in events if e["type"] == "dr")
    assert dr["t_wall"] == pytest.approx(1.040, abs=TICK)


def test_a_partition_is_reported_once_and_healed_when_a_link_returns():
    ctl = Controller(make_config(backup_sdc=None), now=0.0)
    _visc_on(ctl, now=1.0)
    s1 = ctl.dpids["s1"]
    switches = set(ctl.dpids)
    cut = sorted(p for (sw, p), key in ctl.port_links.items() if sw == "s1" and key <= switches)
    for port in cut:  # every way from the SDC's switch to the turbine's side
        ctl.port_status(s1, port, up=False, now=1.5)
    events = []
    for k in range(500):  # 1 s of ticks, the turbine reporting its loss all along
        now = round(1.5 + k * TICK, 6)
        if k % 5 == 0:
            _ak(ctl, "wt1_1", k + 1, 0, now - 1.5, now)
            _hb(ctl, "sdc1", k + 1, now)
        ctl.tick(now)
        events += ctl.take_events()
    kinds = [e["type"] for e in events]
    assert kinds.count("no_path") == 1 and "reroute_failed" not in kinds
    assert str(ctl.tables.t3["wt1_1"]).endswith("/0")
    actions = ctl.port_status(s1, cut[0], up=True, now=2.6)
    assert any(isinstance(a, fl.FlowAdd) for a in actions)
    (restored,) = [e for e in ctl.take_events() if e["type"] == "path_restored"]
    assert restored["wt"] == "wt1_1" and restored["t_loss"] == pytest.approx(1.5, abs=0.01)
    assert str(ctl.tables.t3["wt1_1"]).endswith("/1") and not ctl.partitioned
    cmds = [decode_out(a) for a in actions if isinstance(a, fl.PacketOut) and not is_learn(a)]
    assert {m["cmd"] for _, _, m in cmds} >= {wire.Command.START_INSTANCE, wire.Command.STREAM_START}  # re-engaged


def test_the_ak_that_confirms_the_hold_reroutes_at_once_without_waiting_for_a_tick():
    ctl = Controller(make_config(), now=0.0)
    for k in range(1, 100):
        _hb(ctl, "sdc1", k, 0.01 * k)
        _hb(ctl, "sdc2", k, 0.01 * k + 0.001)
    _visc_on(ctl, now=0.5)
    ctl.take_events()
    for k in range(1, 50):  # control packets arrive normally until 1.0 s
        _ak(ctl, "wt1_1", k, 1, 0.0, 0.5 + 0.01 * k)
    t_loss = 1.0
    for k, age in enumerate((0.010, 0.020, 0.030), start=50):  # AK = 0 reports, no tick in between
        assert _ak(ctl, "wt1_1", k, 0, age, t_loss + age) == []
        _hb(ctl, "sdc1", 100 + k, t_loss + age + 0.0001)
    actions = _ak(ctl, "wt1_1", 53, 0, 0.0401, t_loss + 0.0401)  # the turbine's report at the hold
    (dr,) = [e for e in ctl.take_events() if e["type"] == "dr"]
    assert dr["t_wall"] == pytest.approx(t_loss + 0.0401) and dr["t_loss"] == pytest.approx(t_loss)
    assert any(isinstance(a, fl.FlowAdd) for a in actions)  # the new path's flows, from the packet-in itself


def test_dr_that_does_not_bring_control_back_backs_off():
    from sdn_app.dr import DrMonitor

    m = DrMonitor(hold_s=0.040, ak_timeout_s=0.030)
    m.start("wt1_1", now=0.0)
    m.on_ak("wt1_1", 1, 1, 1, 0.0, now=1.0)
    fired, now, seq = [], 1.0, 1
    while now < 2.0:  # the loss is not the path's: every reroute leaves it as it was
        now = round(now + 0.002, 6)
        if round(now * 1000) % 10 == 0:
            seq += 1
            m.on_ak("wt1_1", seq, 0, 1, now - 1.0, now)
        for wt, _ in m.due(["wt1_1"], now):
            fired.append(now)
            m.start(wt, now)  # what a reroute does
    gaps = [b - a for a, b in zip(fired, fired[1:])]
    assert fired[0] == pytest.approx(1.04, abs=0.011)
    assert gaps[:3] == pytest.approx([0.08, 0.16, 0.32], abs=0.011)  # 40 ms, then doubled each time (10 ms AKs)
    m.on_ak("wt1_1", seq + 1, 1, 2, 0.0, now + 0.01)
    assert m.hold_of("wt1_1") == 0.040  # control came back: the next DR waits 40 ms again


def test_bad_ids_are_dropped_and_answered_without_an_exception():
    ctl = Controller(make_config(backup_sdc=None), now=0.0)
    o = ctl.config.topology.hosts["owfcc"].model_dump()
    bad = wire.encode(wire.MsgType.REQUEST, {"req_id": 1, "cmd": int(wire.Command.VISC_ON), "wt": 1, "sdc_ip": 0,
                                             "mask": 0, "h": 0.0, "d": 0.0, "m_q": 0.0, "v_ref": 0.0, "q_ref": 0.0,
                                             "supp": 0}, header=wire.Header(1, 0, 0))
    out = ctl.packet_in(*ingress(ctl, "owfcc"), frame(o, bad), now=1.0)
    assert len(out) == 1 and ctl.counters["drop_unknown_turbine"] == 1  # answered UNKNOWN_TURBINE
    wt = ctl.config.topology.hosts["wt1_1"].model_dump()
    for wid in (1, -2**31, 2**31 - 1, 0):
        ak = wire.encode(wire.MsgType.AK, {"wt": wid, "seq": 1, "ak": 1, "ctrl_rx": 0, "ctrl_age_ms": 0.0},
                         header=wire.Header(1, 0, 0))
        assert ctl.packet_in(3, 1, frame(wt, ak), now=1.1) == []
    sdc = ctl.config.topology.hosts["sdc1"].model_dump()
    reply = wire.encode(wire.MsgType.REPLY, {"req_id": 1, "status": 0, "wt": 1, "cmd": 1, "detail": 0},
                        header=wire.Header(1, 0, 0))
    assert ctl.packet_in(*ingress(ctl, "sdc1"), frame(sdc, reply), now=1.2) == []
    assert ctl.counters["drop_ak_unregistered"] == 4 and ctl.counters["drop_reply_unexpected"] == 1


def test_ingress_port_check_where_the_turbine_is_on_an_openflow_port():
    desc = describe(topos["farm"](clusters=5, turbines=10, layout="compact"))
    ctl = Controller(AppConfig.model_validate({"topology": desc, "backup_sdc": None}), now=0.0)
    _visc_on(ctl, now=1.0)
    home = ingress(ctl, "wt1_1")
    _ak(ctl, "wt1_1", 1, 0, 0.05, 1.1, where=(home[0], home[1] + 1))  # the victim's IP and MAC, another port
    assert ctl.counters["drop_ak_wrong_port"] == 1 and ctl.dr.tracks["wt1_1"].seq == -1
    _ak(ctl, "wt1_1", 2, 1, 0.0, 1.2, where=home)
    assert ctl.dr.tracks["wt1_1"].seq == 2


def _real_payloads():
    ak = wire.encode(wire.MsgType.AK, {"wt": 101, "seq": 5, "ak": 0, "ctrl_rx": 1, "ctrl_age_ms": 50.0},
                     header=wire.Header(5, 0, 0))
    hb = wire.encode(wire.MsgType.HEARTBEAT, {"sdc_id": 1, "seq": 5, "n_instances": 1, "t_wall": 0.0},
                     header=wire.Header(5, 0, 0))
    reply = wire.encode(wire.MsgType.REPLY, {"req_id": 1, "status": 0, "wt": 101, "cmd": 1, "detail": 0},
                        header=wire.Header(1, 0, 0))
    return [ak, hb, reply, request(wire.Command.VISC_ON), request(wire.Command.SET_PARAMS)]


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(which=st.integers(0, 4), sender=st.sampled_from(["wt1_1", "sdc1", "owfcc"]),
       flips=st.lists(st.integers(0, 8 * 64 - 1), max_size=4), cut=st.integers(0, 80), extra=st.binary(max_size=8))
def test_packet_in_never_raises_on_mutated_messages(which, sender, flips, cut, extra):
    """The app's receive step: a mutated real message from a registered host is used or dropped
    and counted; it never raises (an exception would be lost in os-ken's event loop)."""
    ctl = Controller(make_config(), now=0.0)
    _visc_on(ctl, now=1.0)
    data = bytearray(_real_payloads()[which])
    for bit in flips:
        if bit // 8 < len(data):
            data[bit // 8] ^= 1 << (bit % 8)
    payload = bytes(data[:cut]) + extra if cut < len(data) else bytes(data) + extra
    host = ctl.config.topology.hosts[sender].model_dump()
    where = ingress(ctl, sender) if sender != "wt1_1" else (3, 1)
    before = sum(ctl.counters.values())
    ctl.packet_in(*where, frame(host, payload), now=1.1)
    ctl.tick(1.2)
    assert sum(ctl.counters.values()) > before  # counted: used (requests, ak_rx, heartbeats, ...) or dropped


def test_a_dr_after_the_turbine_fell_back_reengages_it():
    """A loss longer than the turbine's fallback time (it is on its own control, the SDC's instance
    ran open loop): the reroute also starts the SDC instance and the turbine's stream again."""
    ctl = Controller(make_config(backup_sdc=None, turbine_fallback_s=0.1), now=0.0)
    _visc_on(ctl, now=1.0)
    _ak(ctl, "wt1_1", 1, 1, 0.0, 1.6)
    for k in range(1, 6):
        _hb(ctl, "sdc1", k, 1.6 + 0.01 * k)
    _ak(ctl, "wt1_1", 2, 0, 0.030, 1.63)
    short = ctl.tick(1.64)
    assert short == []
    first = _ak(ctl, "wt1_1", 3, 0, 0.041, 1.641)  # a 41 ms loss: reroute only (on the AK that reports it)
    cmds = [decode_out(a)[2]["cmd"] for a in first if isinstance(a, fl.PacketOut) and not is_learn(a)]
    assert any(isinstance(a, fl.FlowAdd) for a in first) and cmds == []
    for barrier in [a for a in first if isinstance(a, fl.Barrier)]:  # the switches acknowledge the new path
        ctl.barrier_reply(barrier.dpid, barrier.tag, 1.645)
    second = _ak(ctl, "wt1_1", 4, 0, 0.160, 1.76)  # the loss goes on for 160 ms: the turbine has fallen back
    cmds = {decode_out(a)[2]["cmd"] for a in second if isinstance(a, fl.PacketOut) and not is_learn(a)}
    assert cmds == {wire.Command.START_INSTANCE, wire.Command.STREAM_START}
