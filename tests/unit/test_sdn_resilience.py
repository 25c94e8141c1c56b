"""DR timing, rerouting and SDC failover in the pure SDN logic, with an injected clock."""

from __future__ import annotations

import pytest

from sdn_app import flows as fl
from sdn_app.dr import DrMonitor
from sdn_app.logic import Controller
from sdn_app.paths import path_links
from sdvisc import wire
from tests.unit.test_sdn_logic import decode_out, frame, ingress, is_learn, make_config, request

HOLD = 0.040


def test_dr_confirmed_by_the_turbines_report_that_the_loss_lasted_the_hold():
    m = DrMonitor(hold_s=HOLD, ak_timeout_s=0.030)
    m.start("wt1_1", now=0.0)
    assert m.on_ak("wt1_1", 1, 1, 10, 0.0005, now=1.000)
    # the AK of 1.020 reports the last control packet 15 ms ago: the loss began at 1.005
    assert m.on_ak("wt1_1", 2, 0, 12, 0.015, now=1.020)
    assert m.on_ak("wt1_1", 3, 0, 12, 0.025, now=1.030)
    assert m.on_ak("wt1_1", 4, 0, 12, 0.035, now=1.040)
    assert m.due(["wt1_1"], now=1.049) == []  # 44 ms since the loss began, but no report says 40 ms yet
    assert m.on_ak("wt1_1", 5, 0, 12, 0.045, now=1.050)  # the turbine: no control packet for 45 ms
    assert m.due(["wt1_1"], now=1.050) == [("wt1_1", pytest.approx(1.005))]
    assert m.due(["wt1_1"], now=1.100) == []  # once per loss
    assert m.on_ak("wt1_1", 6, 1, 13, 0.0003, now=1.110)  # packets flow again: rearmed
    assert m.on_ak("wt1_1", 7, 0, 13, 0.012, now=1.130)
    assert m.on_ak("wt1_1", 8, 0, 13, 0.040, now=1.158)
    assert m.due(["wt1_1"], now=1.158) == [("wt1_1", pytest.approx(1.118))]


def test_a_delayed_ak_is_not_a_dr():
    """A short gap (AK = 0 for 15 ms), then packets again: the AK = 1 that says so is delayed by
    60 ms in a busy switch. The turbine never reported a 40 ms loss, so there is no DR, whichever
    order the reports arrive in; the loss start comes from the send time, not the arrival."""
    m = DrMonitor(hold_s=HOLD, ak_timeout_s=0.030)
    m.start("wt1_1", now=0.0)
    m.on_ak("wt1_1", 1, 1, 10, 0.0, now=1.000, sent=1.000)
    m.on_ak("wt1_1", 2, 0, 10, 0.015, now=1.021, sent=1.015)
    for now in (1.030, 1.045, 1.060, 1.075):
        assert m.due(["wt1_1"], now=now, stalled=True) == []  # no packet-in from anyone: our stall
    m.on_ak("wt1_1", 3, 1, 20, 0.0005, now=1.080, sent=1.020)
    assert m.loss_since("wt1_1", now=1.081) is None and m.due(["wt1_1"], now=1.081) == []


def test_missing_ak_counts_as_zero():
    m = DrMonitor(hold_s=HOLD, ak_timeout_s=0.030)
    m.start("wt1_1", now=0.0)
    m.on_ak("wt1_1", 1, 1, 10, 0.0, now=2.0)
    assert m.loss_since("wt1_1", now=2.029) is None
    assert m.loss_since("wt1_1", now=2.031) == pytest.approx(2.0)
    assert m.due(["wt1_1"], now=2.0 + HOLD - 1e-6) == []
    assert [w for w, _ in m.due(["wt1_1"], now=2.0 + HOLD + 1e-6)] == ["wt1_1"]


def test_duplicate_and_old_ak_ignored():
    m = DrMonitor()
    assert m.on_ak("wt1_1", 5, 1, 1, 0.0, now=1.0)
    assert not m.on_ak("wt1_1", 5, 0, 1, 0.5, now=1.01)
    assert not m.on_ak("wt1_1", 4, 0, 1, 0.5, now=1.01)
    assert m.loss_since("wt1_1", now=1.01) is None


def ak(ctl, seq, value, age_s, now):
    wt = ctl.config.topology.hosts["wt1_1"].model_dump()
    payload = wire.encode(wire.MsgType.AK, {"wt": 101, "seq": seq, "ak": value, "ctrl_rx": seq,
                                            "ctrl_age_ms": age_s * 1e3}, header=wire.Header(seq, 0, 0))
    return ctl.packet_in(3, 1, frame(wt, payload), now)


def heartbeat(ctl, sdc, seq, now):
    h = ctl.config.topology.hosts[sdc].model_dump()
    payload = wire.encode(wire.MsgType.HEARTBEAT, {"sdc_id": int(sdc[-1]), "seq": seq, "n_instances": 1,
                                                   "t_wall": now % 1e4},
                          header=wire.Header(seq, int(now), int((now % 1) * 1e9)))
    return ctl.packet_in(*ingress(ctl, sdc), frame(h, payload), now)


def visc_on(ctl, now=1.0):
    owfcc = ctl.config.topology.hosts["owfcc"].model_dump()
    return ctl.packet_in(1, 4, frame(owfcc, request(wire.Command.VISC_ON)), now)


def test_dr_reroutes_on_a_link_disjoint_path_after_the_hold():
    ctl = Controller(make_config(backup_sdc=None), now=0.0)
    visc_on(ctl, 1.0)
    old = ctl.paths["wt1_1"].path
    ak(ctl, 1, 1, 0.0, 1.5)
    ak(ctl, 2, 0, 0.012, 1.52)  # loss since 1.508 (no port status seen: silent failure)
    ak(ctl, 3, 0, 0.032, 1.54)
    assert ctl.tick(1.548) == []
    # the turbine reports a loss as long as the hold: its AK reroutes at once (no tick waited for)
    actions = ak(ctl, 4, 0, 0.041, 1.508 + HOLD + 0.001)
    deletes = [a for a in actions if isinstance(a, fl.FlowDelete)]
    adds = [a for a in actions if isinstance(a, fl.FlowAdd)]
    assert deletes and all(d.cookie == fl.turbine_cookie(101) for d in deletes)
    new = ctl.paths["wt1_1"].path
    inner = lambda p: set(path_links(p)[1:-1])  # noqa: E731 - switch-to-switch links only
    assert new != old and not (inner(new) & inner(old))
    assert {a.dpid for a in adds} == {ctl.dpids[n] for n in new if n in ctl.dpids}
    (event,) = [e for e in ctl.take_events() if e["type"] == "dr"]
    assert event["t_loss"] == pytest.approx(1.508) and event["t_detect"] == pytest.approx(1.508 + HOLD + 0.001)
    assert any(is_learn(a) for a in actions if isinstance(a, fl.PacketOut))


def test_dr_avoids_only_the_known_down_link_and_port_status_can_act_at_once():
    ctl = Controller(make_config(backup_sdc=None), now=0.0)
    visc_on(ctl, 1.0)
    s1_s3 = next(p for (sw, p), key in ctl.port_links.items() if sw == "s1" and "s3" in key)
    assert ctl.port_status(1, s1_s3, up=False, now=1.5) == []  # paper: wait for DR
    assert str(ctl.tables.t3["wt1_1"]) == "1/1"  # another link exists
    ak(ctl, 1, 0, 0.010, 1.52)  # loss since 1.51; then the turbine's AKs stop too
    for k, t in enumerate((1.525, 1.535, 1.545)):  # the controller still receives packets: not its own stall
        heartbeat(ctl, "sdc1", 1 + k, t)
    assert ctl.tick(1.549) == []
    assert ctl.tick(1.551)  # no AK for 30 ms and the loss has lasted 40 ms
    assert frozenset(("s1", "s3")) not in path_links(ctl.paths["wt1_1"].path)

    fast = Controller(make_config(backup_sdc=None, reroute_on_port_status=True), now=0.0)
    visc_on(fast, 1.0)
    actions = fast.port_status(1, s1_s3, up=False, now=1.5)
    assert any(isinstance(a, fl.FlowAdd) for a in actions)
    assert frozenset(("s1", "s3")) not in path_links(fast.paths["wt1_1"].path)
    assert [e["type"] for e in fast.take_events()][-1] == "port_status"


def test_mirroring_keeps_the_backup_warm():
    ctl = Controller(make_config(), now=0.0)
    heartbeat(ctl, "sdc1", 1, 0.9)
    heartbeat(ctl, "sdc2", 1, 0.9)
    actions = visc_on(ctl, 1.0)
    s1 = [a for a in actions if isinstance(a, fl.FlowAdd) and a.dpid == 1 and a.match.get("ipv4_dst") == "10.0.0.21"]
    (up,) = s1
    sdc1_port = ctl.config.topology.hosts["sdc1"].port
    assert up.out_ports[0] == sdc1_port and len(up.out_ports) == 2
    assert fl.SetField("ipv4_dst", "10.0.0.22") in up.actions
    s2 = [a for a in actions if isinstance(a, fl.FlowAdd) and a.dpid == 2]
    assert s2 and s2[0].match["ipv4_dst"] == "10.0.0.22"
    assert s2[0].out_ports == [ctl.config.topology.hosts["sdc2"].port]


@pytest.mark.parametrize("failover", [True, False])
def test_dead_primary_fails_over_with_address_rewrite(failover):
    ctl = Controller(make_config(failover=failover, sdc_dead_s=0.030), now=0.0)
    heartbeat(ctl, "sdc1", 1, 0.99)
    heartbeat(ctl, "sdc2", 1, 0.99)
    visc_on(ctl, 1.0)
    for k in range(1, 51):  # both SDCs beat every 10 ms up to 1.50, then the primary stops
        heartbeat(ctl, "sdc1", 1 + k, 1.0 + 0.01 * k)
        heartbeat(ctl, "sdc2", 1 + k, 1.0 + 0.01 * k)
    ak(ctl, 1, 1, 0.001, 1.50)
    heartbeat(ctl, "sdc2", 52, 1.51)
    ak(ctl, 2, 0, 0.012, 1.512)
    heartbeat(ctl, "sdc2", 53, 1.52)
    ak(ctl, 3, 0, 0.025, 1.525)  # wt1_1 has had no control packet since 1.50
    assert ctl.tick(1.529) == []
    actions = ctl.tick(1.531)
    events = [e["type"] for e in ctl.take_events()]
    assert "sdc_dead" in events
    if not failover:
        assert actions == [] and "failover_unavailable" in events
        assert ctl.tick(1.60) == []  # DR is not triggered for a turbine whose SDC is dead
        return
    assert "sdc_failover" in events and ctl.active_sdc == "sdc2"
    adds = [a for a in actions if isinstance(a, fl.FlowAdd)]
    at_s2 = [a for a in adds if a.dpid == 2]
    up = next(a for a in at_s2 if a.match["ipv4_dst"] == "10.0.0.21")  # the turbine still addresses sdc1
    assert fl.SetField("ipv4_dst", "10.0.0.22") in up.actions
    assert up.out_ports == [ctl.config.topology.hosts["sdc2"].port]
    down = next(a for a in at_s2 if a.match["ipv4_src"] == "10.0.0.22")
    assert fl.SetField("ipv4_src", "10.0.0.21") in down.actions
    cmds = [decode_out(a) for a in actions if isinstance(a, fl.PacketOut) and not is_learn(a)]
    assert ("10.0.0.22", wire.PORT_SDC) in {(d, p) for d, p, m in cmds if m["cmd"] == wire.Command.TAKEOVER}
    assert ctl.paths["wt1_1"].sdc == "sdc2" and ctl.paths["wt1_1"].path[0] == "sdc2"


def test_fresh_start_is_not_mistaken_for_a_failure():
    m = DrMonitor(hold_s=HOLD, ak_timeout_s=0.030, start_grace_s=0.5)
    m.start("wt1_1", now=1.0, armed=False)
    m.on_ak("wt1_1", 1, 0, 0, 1e3, now=1.01)  # the SDC has not answered yet
    assert m.due(["wt1_1"], now=1.2) == []
    m.on_ak("wt1_1", 2, 1, 5, 0.001, now=1.03)  # communication established: armed
    m.on_ak("wt1_1", 3, 0, 9, 0.012, now=1.10)
    assert m.due(["wt1_1"], now=1.129) == []  # reported 12 ms, AKs still expected
    assert [w for w, _ in m.due(["wt1_1"], now=1.131)] == ["wt1_1"]  # then no AK for 30 ms: AK = 0 goes on
    # a turbine whose SDC never answers is reported once the start-up grace is over
    m.start("wt1_2", now=2.0, armed=False)
    m.on_ak("wt1_2", 1, 0, 0, 1e3, now=2.01)
    assert m.due(["wt1_2"], now=2.5 + HOLD - 1e-3) == []
    assert [w for w, _ in m.due(["wt1_2"], now=2.5 + HOLD + 1e-3)] == ["wt1_2"]


def test_all_sdcs_silent_at_once_is_not_a_failover():
    ctl = Controller(make_config(sdc_dead_s=0.030), now=0.0)
    heartbeat(ctl, "sdc1", 1, 0.99)
    heartbeat(ctl, "sdc2", 1, 0.99)
    visc_on(ctl, 1.0)
    heartbeat(ctl, "sdc1", 2, 1.30)
    heartbeat(ctl, "sdc2", 2, 1.30)
    assert ctl.tick(1.40) == []  # both stale: our own stall, not two deaths
    assert ctl.active_sdc == "sdc1" and not ctl.sdc_dead
    ak(ctl, 1, 1, 0.001, 1.32)
    ak(ctl, 2, 1, 0.001, 1.41)  # packets again after a stall; wt1_1 served until 1.411
    heartbeat(ctl, "sdc2", 3, 1.41)
    # sdc1's heartbeats may still be queued behind the stall: its silence counts from its end
    assert ctl.tick(1.42) == [] and ctl.active_sdc == "sdc1"
    actions = []
    for k, t in enumerate((1.42, 1.43, 1.44)):  # wt1_1 reports its loss (since 1.411: below the hold)
        heartbeat(ctl, "sdc2", 4 + k, t)
        actions += ak(ctl, 3 + k, 0, t - 1.411, t)
    actions += ctl.tick(1.441)
    assert actions and ctl.active_sdc == "sdc2"  # sdc1 silent 30 ms after the stall, sdc2 alive: fail over
    kinds = [e["type"] for e in ctl.take_events()]
    assert "sdc_failover" in kinds and "dr" not in kinds  # (decided on the AK at 1.44 or the tick)


def test_late_heartbeats_while_turbines_are_served_are_not_a_death():
    ctl = Controller(make_config(sdc_dead_s=0.030), now=0.0)
    heartbeat(ctl, "sdc1", 1, 0.99)
    heartbeat(ctl, "sdc2", 1, 0.99)
    visc_on(ctl, 1.0)
    assert ctl.tick(1.1) == []  # settling after our own flow changes: no decision at all
    for k in range(11):  # 1.20 ... 1.30: both SDCs beat, the turbine is served
        t = round(1.20 + 0.01 * k, 3)
        heartbeat(ctl, "sdc1", 2 + k, t)
        heartbeat(ctl, "sdc2", 2 + k, t)
        ak(ctl, 1 + k, 1, 0.001, t)
    for k in range(1, 7):  # 1.31 ... 1.36: sdc1's heartbeats are late, wt1_1 is still served
        t = round(1.30 + 0.01 * k, 3)
        heartbeat(ctl, "sdc2", 12 + k, t)
        ak(ctl, 11 + k, 1, 0.001, t)
    assert ctl.tick(1.365) == [] and not ctl.sdc_dead
    ak(ctl, 18, 0, 0.015, 1.37)  # now wt1_1 reports a loss too, but only of 15 ms: not yet evidence
    heartbeat(ctl, "sdc2", 19, 1.37)
    assert ctl.tick(1.372) == [] and not ctl.sdc_dead
    actions = ak(ctl, 19, 0, 0.025, 1.38)  # 25 ms without control packets, sdc1 silent for 80 ms: dead
    heartbeat(ctl, "sdc2", 20, 1.38)
    assert actions + ctl.tick(1.381) and ctl.active_sdc == "sdc2"


def _barriers(actions):
    return [a for a in actions if isinstance(a, fl.Barrier)]


def _lose_control(ctl, seq0, since, until, start=None, now_step=0.010, actions=None):
    """AKs = 0 every 10 ms after ``start`` (default ``since``) until ``until``, each reporting the
    loss since ``since`` (the turbine's own report); what the app sent in reply goes to ``actions``."""
    seq, now = seq0, (since if start is None else start) + now_step
    while now <= until + 1e-9:
        seq += 1
        out = ak(ctl, seq, 0, now - since, round(now, 6))
        if actions is not None:
            actions += out
        now += now_step
    return seq


def test_every_switch_of_a_new_path_gets_a_barrier_and_a_late_reply_is_not_a_second_dr():
    """On a loaded machine the new path takes 60 ms to be acknowledged: the hold counts from then
    (plus the measured one-way delay), so the same failure does not cause a second reroute."""
    ctl = Controller(make_config(backup_sdc=None), now=0.0)
    first_path = visc_on(ctl, 1.0)
    assert {b.dpid for b in _barriers(first_path)} == {a.dpid for a in first_path if isinstance(a, fl.FlowAdd)}
    for b in _barriers(first_path):
        ctl.barrier_reply(b.dpid, b.tag, 1.01)
    ak(ctl, 1, 1, 0.0, 1.5)
    rerouted = []
    seq = _lose_control(ctl, 1, 1.508, 1.549, actions=rerouted)  # the AK at 1.548 reports the hold: DR at once
    rerouted += ctl.tick(1.550)
    barriers = _barriers(rerouted)
    new_path = ctl.paths["wt1_1"]
    assert {b.dpid for b in barriers} == {ctl.dpids[n] for n in new_path.path if n in ctl.dpids}
    assert all(b.tag == f"wt1_1#{new_path.reroutes}" for b in barriers)
    # the turbine keeps reporting the loss while the switches are slow to install the new path
    seq = _lose_control(ctl, seq, 1.508, 1.600, start=1.549)
    assert [e for e in ctl.take_events() if e["type"] == "dr"][0]["t_detect"] == pytest.approx(1.548)
    assert ctl.tick(1.600) == []  # 50 ms after the reroute: without readiness this was a second DR
    for b in barriers[:-1]:
        ctl.barrier_reply(b.dpid, b.tag, 1.610)
        ctl.barrier_reply(b.dpid, b.tag, 1.610)  # a duplicate reply changes nothing
    ctl.barrier_reply(barriers[0].dpid, "wt1_1#0", 1.611)  # a reply for the old path version neither
    assert ctl.tick(1.615) == [] and new_path.ready_at is None
    ctl.barrier_reply(barriers[-1].dpid, barriers[-1].tag, 1.612)
    assert new_path.ready_at == pytest.approx(1.612)
    (ready,) = [e for e in ctl.take_events() if e["type"] == "path_ready"]  # reported once, for the new version
    assert ready["version"] == new_path.reroutes and ready["after_ms"] == pytest.approx(64.0)  # installed at 1.548
    ak(ctl, seq + 1, 1, 0.0005, 1.618)  # the new path delivers: no DR at all
    assert ctl.tick(1.700) == [] and not [e for e in ctl.take_events() if e["type"] == "dr"]


def test_a_new_path_that_does_not_deliver_is_detected_after_the_hold_from_its_readiness():
    ctl = Controller(make_config(backup_sdc=None), now=0.0)
    visc_on(ctl, 1.0)
    ak(ctl, 1, 1, 0.0, 1.5)
    rerouted = []
    seq = _lose_control(ctl, 1, 1.508, 1.549, actions=rerouted)
    barriers = _barriers(rerouted + ctl.tick(1.550))
    for b in barriers:
        ctl.barrier_reply(b.dpid, b.tag, 1.560)
    ctl.take_events()
    # control does not come back over the new path: the second DR waits the (doubled) hold from 1.560
    early = []
    seq = _lose_control(ctl, seq, 1.508, 1.60, start=1.549, actions=early)
    assert early + ctl.tick(1.60) == []
    second = []
    _lose_control(ctl, seq, 1.508, 1.66, start=1.60, actions=second)
    assert any(isinstance(a, fl.FlowAdd) for a in second + ctl.tick(1.66))
    (dr,) = [e for e in ctl.take_events() if e["type"] == "dr"]
    assert dr["t_loss"] >= 1.560


def test_without_any_acknowledgement_the_hold_is_armed_after_the_ready_timeout():
    from sdn_app.dr import READY_TIMEOUT_S, DrMonitor

    m = DrMonitor(hold_s=HOLD, ak_timeout_s=0.030)
    m.start("wt1_1", now=0.0)
    m.on_ak("wt1_1", 1, 1, 1, 0.0, now=1.0, sent=0.998)
    assert m.tracks["wt1_1"].one_way_s == pytest.approx(0.2 * 0.002)  # exponential average of the AKs' delay
    m.start("wt1_1", now=1.0, await_path=True)  # rerouted, no barrier reply ever comes (switch gone)
    assert m.loss_since("wt1_1", now=1.0 + READY_TIMEOUT_S - 1e-3) is None
    m.on_ak("wt1_1", 2, 0, 1, 0.2, now=1.2, sent=1.2)
    assert m.loss_since("wt1_1", now=1.2) == pytest.approx(1.0 + READY_TIMEOUT_S)


def test_a_loss_dated_before_the_last_restart_never_confirms_a_dr():
    """After a partition heals (restart at 3.506) no DR may be dated before it: seen once in a full
    test pass, a DR 8 ms after the restart carried the loss start of the partition (2.654)."""
    m = DrMonitor(hold_s=HOLD, ak_timeout_s=0.030)
    m.start("wt4_1", now=2.554, await_path=True)  # the reroute that found no path
    m.start("wt4_1", now=3.506, await_path=True)  # the partition heals: a new path
    m.path_ready("wt4_1", now=3.510)
    track = m.tracks["wt4_1"]
    track.t_loss, track.t_reported = 2.654, 3.512  # a loss start left from before the restart (however it got there)
    assert m.due(["wt4_1"], now=3.515) == []
    m.tracks["wt4_1"].t_loss = 3.511  # dated after the restart: it counts (the turbine reports it lasted the hold)
    m.tracks["wt4_1"].t_reported = 3.560
    assert m.due(["wt4_1"], now=3.560) == [("wt4_1", pytest.approx(3.511))]
