"""DR timing, rerouting and SDC failover in the pure SDN logic, with an injected clock."""

from __future__ import annotations

import pytest

from sdn_app import flows as fl
from sdn_app.dr import DrMonitor
from sdn_app.logic import Controller
from sdn_app.paths import path_links
from sdvisc import wire
from tests.unit.test_sdn_logic import decode_out, frame, is_learn, make_config, request

HOLD = 0.040


def test_dr_not_before_hold_and_right_after():
    m = DrMonitor(hold_s=HOLD, ak_timeout_s=0.030)
    m.start("wt1_1", now=0.0)
    assert m.on_ak("wt1_1", 1, 1, 10, 0.0005, now=1.000)
    # the AK of 1.020 reports the last control packet 15 ms ago: the loss began at 1.005
    assert m.on_ak("wt1_1", 2, 0, 12, 0.015, now=1.020)
    assert m.due(["wt1_1"], now=1.005 + HOLD - 1e-6) == []
    assert m.due(["wt1_1"], now=1.005 + HOLD + 1e-6) == [("wt1_1", pytest.approx(1.005))]
    assert m.due(["wt1_1"], now=1.100) == []  # once per loss
    assert m.on_ak("wt1_1", 3, 1, 13, 0.0003, now=1.110)  # packets flow again: rearmed
    assert m.on_ak("wt1_1", 4, 0, 13, 0.012, now=1.130)
    assert m.due(["wt1_1"], now=1.118 + HOLD + 1e-6) == [("wt1_1", pytest.approx(1.118))]


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
    return ctl.packet_in(1, 1, frame(h, payload), now)


def visc_on(ctl, now=1.0):
    owfcc = ctl.config.topology.hosts["owfcc"].model_dump()
    return ctl.packet_in(1, 4, frame(owfcc, request(wire.Command.VISC_ON)), now)


def test_dr_reroutes_on_a_link_disjoint_path_after_the_hold():
    ctl = Controller(make_config(backup_sdc=None), now=0.0)
    visc_on(ctl, 1.0)
    old = ctl.paths["wt1_1"].path
    ak(ctl, 1, 1, 0.0, 1.5)
    ak(ctl, 2, 0, 0.012, 1.52)  # loss since 1.508 (no port status seen: silent failure)
    assert ctl.tick(1.508 + HOLD - 0.001) == []
    actions = ctl.tick(1.508 + HOLD + 0.001)
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
    ak(ctl, 1, 0, 0.010, 1.52)  # loss since 1.51
    assert ctl.tick(1.51 + HOLD - 0.001) == []
    assert ctl.tick(1.51 + HOLD + 0.001)
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
    heartbeat(ctl, "sdc1", 2, 1.50)  # last heartbeat of the primary
    for i, t in enumerate((1.52, 1.54, 1.56)):
        heartbeat(ctl, "sdc2", 2 + i, t)
    ak(ctl, 1, 1, 0.001, 1.30)
    ak(ctl, 2, 0, 0.04, 1.54)  # wt1_1 has had no control packet since 1.50
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
    assert [w for w, _ in m.due(["wt1_1"], now=1.088 + HOLD + 1e-6)] == ["wt1_1"]
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
    ak(ctl, 2, 0, 0.02, 1.41)  # and wt1_1 has lost its control packets
    heartbeat(ctl, "sdc2", 3, 1.41)
    assert ctl.tick(1.42)  # now only sdc1 is silent: fail over
    assert ctl.active_sdc == "sdc2"


def test_late_heartbeats_while_turbines_are_served_are_not_a_death():
    ctl = Controller(make_config(sdc_dead_s=0.030), now=0.0)
    heartbeat(ctl, "sdc1", 1, 0.99)
    heartbeat(ctl, "sdc2", 1, 0.99)
    visc_on(ctl, 1.0)
    assert ctl.tick(1.1) == []  # settling after our own flow changes: no decision at all
    heartbeat(ctl, "sdc1", 2, 1.30)
    ak(ctl, 1, 1, 0.001, 1.32)
    heartbeat(ctl, "sdc2", 2, 1.35)
    ak(ctl, 2, 1, 0.001, 1.36)  # wt1_1 is served fine although sdc1's heartbeats are late
    assert ctl.tick(1.365) == [] and not ctl.sdc_dead
    ak(ctl, 3, 0, 0.015, 1.38)  # now wt1_1 has lost its control packets too: sdc1 is dead
    heartbeat(ctl, "sdc2", 3, 1.38)
    assert ctl.tick(1.385) and ctl.active_sdc == "sdc2"
