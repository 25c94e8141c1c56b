"""The controller's intake socket, without switches: the intake network in the topology's
description, the flows that feed it, and decisions from its datagrams equal to those from
packet-ins (same inputs, injected clock)."""

from __future__ import annotations

import pytest
from os_ken.ofproto import ofproto_v1_3, ofproto_v1_3_parser
from pydantic import ValidationError

from scenarios.schema import SdnSpec
from sdn_app import flows as fl
from sdn_app.logic import Controller
from sdn_app.ofmsg import to_messages
from sdvisc import wire
from sdvisc.config import CONTROLLER_VIP, CONTROLLER_VMAC, AppConfig
from tests.unit.test_sdn_logic import frame, ingress, request
from topologies import topos
from topologies.base import INTAKE_BRIDGE, INTAKE_HOST, describe

FARM = {"clusters": 2, "turbines": 2, "layout": "compact"}


def farm(intake: bool):
    topo = topos["farm"](**FARM)
    if intake:
        topo.add_intake(CONTROLLER_VIP, CONTROLLER_VMAC)
    return topo


def controller(intake_socket: bool, **kw) -> Controller:
    desc = describe(farm(intake=True))
    extra = {"intake_socket": {"netns_pid": None}} if intake_socket else {}
    return Controller(AppConfig.model_validate({"topology": desc, "backup_sdc": "sdc2", **extra, **kw}), now=0.0)


def ak(wt: str, seq: int, ak_bit: int) -> bytes:
    return wire.encode(wire.MsgType.AK, {"wt": wire.turbine_id(*wire.parse_turbine(wt)), "seq": seq, "ak": ak_bit,
                                         "ctrl_rx": seq, "ctrl_age_ms": 0.5 if ak_bit else 50.0},
                       header=wire.Header(seq, 0, 0))


def heartbeat(seq: int, sdc_id: int = 1) -> bytes:
    return wire.encode(wire.MsgType.HEARTBEAT, {"sdc_id": sdc_id, "seq": seq, "n_instances": 1, "t_wall": 0.0},
                       header=wire.Header(seq, 0, 0))


def test_the_intake_network_is_not_part_of_the_farms_network():
    plain, with_intake = describe(farm(False)), describe(farm(True))
    assert with_intake["links"] == plain["links"] and with_intake["hosts"] == plain["hosts"]
    assert with_intake["switches"] == plain["switches"], "its bridge is nobody's OpenFlow switch"
    assert INTAKE_HOST not in with_intake["hosts"] and INTAKE_BRIDGE not in with_intake["switches"]
    assert set(with_intake["intake_ports"]) == {n for n, s in plain["switches"].items() if s["openflow"]}
    used = {(h["switch"], h["port"]) for h in plain["hosts"].values()}
    used |= {(lk["a"], lk["a_port"]) for lk in plain["links"]} | {(lk["b"], lk["b_port"]) for lk in plain["links"]}
    assert not used & set(with_intake["intake_ports"].items()), "a port of its own on every switch"
    assert "intake_ports" not in plain


def test_each_switch_forwards_only_its_own_hosts_from_their_own_port_to_the_intake():
    ctl = controller(intake_socket=True)
    hosts = ctl.config.topology.hosts
    for switch, dpid in ctl.dpids.items():
        intake = [a for a in ctl.switch_up(dpid, 0.1) if a.priority == fl.PRIORITY_INTAKE]
        mine = {n: h for n, h in hosts.items() if h.switch == switch}
        assert len(intake) == len(mine)
        for flow in intake:
            name = next(n for n, h in mine.items() if h.ip == flow.match["ipv4_src"])
            assert flow.match["in_port"] == mine[name].port and flow.match["eth_src"] == mine[name].mac
            assert flow.match["ipv4_dst"] == CONTROLLER_VIP and flow.match["udp_dst"] == wire.PORT_CONTROLLER
            assert flow.out_ports == [ctl.config.topology.intake_ports[switch]]
        assert fl.PRIORITY_INTAKE > fl.PRIORITY_TO_CONTROLLER  # the packet-in rule catches only what these refuse
    dp = type("Dp", (), {"ofproto": ofproto_v1_3, "ofproto_parser": ofproto_v1_3_parser, "id": 1})()
    for action in ctl.switch_up(ctl.dpids[hosts["wt1_1"].switch], 0.2):
        for msg in to_messages(action, dp):
            msg.serialize()


def test_without_the_socket_no_switch_forwards_to_the_intake():
    ctl = controller(intake_socket=False)
    assert not any(a.priority == fl.PRIORITY_INTAKE for d in ctl.dpids.values() for a in ctl.switch_up(d, 0.1))
    assert ctl.delivered([("10.0.1.1", ak("wt1_1", 1, 1))], now=0.2) == []
    assert ctl.counters["drop_intake_unknown_source"] == 1


def feed(ctl: Controller, via_socket: bool, sender: str, payload: bytes, now: float) -> list:
    host = ctl.config.topology.hosts[sender]
    if via_socket:
        return ctl.delivered([(host.ip, payload)], now)
    return ctl.packet_in(*ingress(ctl, sender), frame(host.model_dump(), payload), now=now)


def run_story(via_socket: bool) -> tuple[Controller, list]:
    """A request, AKs, heartbeats, an AK = 0 run into a DR, and the time passing (ticks)."""
    ctl = controller(intake_socket=True)
    log = [feed(ctl, via_socket, "owfcc", request(wire.Command.VISC_ON, wt="wt2_1"), 1.0)]
    for barrier in [a for a in log[0] if isinstance(a, fl.Barrier)]:  # every switch has the path's flows
        log.append(ctl.barrier_reply(barrier.dpid, barrier.tag, 1.001))
    t, seq = 1.0, 0
    while t < 1.3:
        t = round(t + 0.01, 3)
        seq += 1
        log.append(feed(ctl, via_socket, "sdc1", heartbeat(seq), t))
        log.append(feed(ctl, via_socket, "sdc2", heartbeat(seq, sdc_id=2), t))
        log.append(feed(ctl, via_socket, "wt2_1", ak("wt2_1", seq, int(t < 1.15)), t))
        log.append(ctl.tick(t))
    return ctl, log


def test_decisions_from_the_socket_equal_those_from_packet_ins():
    by_socket, log_socket = run_story(via_socket=True)
    by_packet_in, log_packet_in = run_story(via_socket=False)
    assert log_socket == log_packet_in
    assert str(by_socket.tables.t3["wt2_1"]) == str(by_packet_in.tables.t3["wt2_1"]) == "0/1"
    events = by_socket.take_events()
    assert events == by_packet_in.take_events()
    assert [e["type"] for e in events if e["type"] in ("visc_on", "path_ready", "dr")] == ["visc_on", "path_ready", "dr"]
    counted = ("ak_rx", "heartbeats", "requests")
    assert {k: by_socket.counters[k] for k in counted} == {k: by_packet_in.counters[k] for k in counted}
    assert by_socket.counters["ak_rx"] > 20 and by_socket.counters["heartbeats"] > 40
    assert by_socket.counters["intake_rx"] == sum(by_socket.counters[k] for k in ("ak_rx", "heartbeats")) + 1
    assert by_socket.counters["packet_in"] == 0 and by_packet_in.counters["intake_rx"] == 0


def test_bad_datagrams_on_the_socket_are_counted_and_dropped_without_harm():
    ctl = controller(intake_socket=True)
    before = str(ctl.tables.t3["wt1_1"])
    actions = ctl.delivered([("10.0.9.9", ak("wt1_1", 1, 1)),  # nobody's address
                             ("10.0.1.1", b"\x00\x00\x00\x04" + b"\xff" * 7),  # malformed
                             ("10.0.1.1", request(wire.Command.VISC_ON, wt="wt1_1")),  # a turbine is no OWFCC
                             ("10.0.1.1", ak("wt1_2", 1, 0))], now=1.0)  # another turbine's AK
    assert actions == []
    assert ctl.counters["drop_intake_unknown_source"] == 1 and ctl.counters["drop_malformed"] == 1
    assert ctl.counters["drop_request_not_owfcc"] == 1 and ctl.counters["drop_ak_unregistered"] == 1
    assert str(ctl.tables.t3["wt1_1"]) == before and not ctl.paths


def test_a_silent_socket_is_the_controllers_own_stall_as_silent_packet_ins_were():
    ctl = controller(intake_socket=True)
    ctl.delivered([(ctl.config.topology.hosts["sdc1"].ip, heartbeat(1))], now=1.0)
    assert not ctl.guard.stalled(1.01) and ctl.guard.stalled(1.03)
    ctl.delivered([(ctl.config.topology.hosts["sdc1"].ip, heartbeat(2))], now=1.05)
    assert ctl.guard.t_resumed == 1.05


def test_the_scenario_chooses_socket_unless_a_redundant_pair_runs():
    assert SdnSpec().uses_intake_socket(has_openflow_switch=True)
    assert not SdnSpec(redundancy=True).uses_intake_socket(True)
    assert not SdnSpec(intake="packet_in").uses_intake_socket(True)
    assert not SdnSpec().uses_intake_socket(has_openflow_switch=False)
    with pytest.raises(ValidationError, match="redundant pair needs packet_in"):
        SdnSpec(redundancy=True, intake="socket")
