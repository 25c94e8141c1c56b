"""SDN application logic without switches: tables, requests, paths, flows, with an injected clock."""

from __future__ import annotations

from types import SimpleNamespace

import pytest
from os_ken.lib.packet import ethernet, ipv4, packet, udp
from os_ken.ofproto import ofproto_v1_3, ofproto_v1_3_parser

from sdn_app import flows as fl
from sdn_app.logic import Controller
from sdn_app.ofmsg import to_messages
from sdn_app.paths import build_graph, choose_path
from sdn_app.tables import TableError, Tables, TurbineAddress, TwoDigit
from sdvisc import wire
from sdvisc.config import CONTROLLER_VIP, CONTROLLER_VMAC, AppConfig
from topologies import topos
from topologies.base import describe


def make_config(**kw) -> AppConfig:
    desc = describe(topos["paper"](clusters=1, turbines=2))
    return AppConfig.model_validate({"topology": desc, **kw})


def frame(src_host: dict, payload: bytes, dst_ip=CONTROLLER_VIP, dst_port=wire.PORT_CONTROLLER) -> bytes:
    pkt = packet.Packet()
    pkt.add_protocol(ethernet.ethernet(dst=CONTROLLER_VMAC, src=src_host["mac"], ethertype=0x0800))
    pkt.add_protocol(ipv4.ipv4(src=src_host["ip"], dst=dst_ip, proto=17))
    pkt.add_protocol(udp.udp(src_port=40000, dst_port=dst_port))
    pkt.add_protocol(payload)
    pkt.serialize()
    return bytes(pkt.data)


def ingress(ctl, host: str) -> tuple[int, int]:
    """(dpid, port) where ``host``'s packets reach the controller (its registered OpenFlow port)."""
    info = ctl.config.topology.hosts[host]
    return ctl.dpids[info.switch], info.port


def request(cmd: wire.Command, wt: str = "wt1_1", req_id: int = 7, **params) -> bytes:
    values = {"req_id": req_id, "cmd": int(cmd), "wt": wire.turbine_id(*wire.parse_turbine(wt)), "sdc_ip": 0,
              "mask": 0, "h": 0.0, "d": 0.0, "m_q": 0.0, "v_ref": 0.0, "q_ref": 0.0, "supp": 0, **params}
    return wire.encode(wire.MsgType.REQUEST, values, header=wire.Header(req_id, 0, 0))


def is_learn(action: fl.PacketOut) -> bool:
    return packet.Packet(action.data).get_protocol(ipv4.ipv4) is None


def decode_out(action: fl.PacketOut) -> tuple[str, int, wire.Message]:
    pkt = packet.Packet(action.data)
    ip, u = pkt.get_protocol(ipv4.ipv4), pkt.get_protocol(udp.udp)
    return ip.dst, u.dst_port, wire.decode(bytes(pkt.protocols[-1]), header=True)


@pytest.fixture
def ctl():
    """No backup SDC: the plain paper case (no mirroring)."""
    return Controller(make_config(backup_sdc=None), now=0.0)


def owfcc(ctl):
    return ctl.config.topology.hosts["owfcc"].model_dump()


# ---------------------------------------------------------------- tables
def test_t2_rejects_one_slash_zero():
    t = Tables()
    t.plug(TurbineAddress("wt1_1", 1, 1, "10.0.1.1", "m", "s3", 1), visc_enabled=False)
    assert str(t.t2["wt1_1"]) == "0/0"
    with pytest.raises(TableError, match="1/0"):
        t.set_mode("wt1_1", True)
    t.set_enabled("wt1_1", True)
    t.set_mode("wt1_1", True)
    assert str(t.t2["wt1_1"]) == "1/1"
    with pytest.raises(TableError):
        t.set_enabled("wt1_1", False)
    t.set_mode("wt1_1", False)
    t.set_enabled("wt1_1", False)
    assert str(t.t2["wt1_1"]) == "0/0"
    with pytest.raises(TableError):
        TwoDigit(2, 0)
    assert TwoDigit.parse("0/1") == TwoDigit(0, 1)


def test_t3_and_unplug():
    t = Tables()
    t.plug(TurbineAddress("wt1_1", 1, 1, "10.0.1.1", "m", "s3", 1))
    assert str(t.t3["wt1_1"]) == "0/0"
    t.set_comm("wt1_1", link_ok=True)
    t.set_comm("wt1_1", comm_on=True)
    assert str(t.t3["wt1_1"]) == "1/1"
    t.unplug("wt1_1")
    assert t.lookup("wt1_1") is None and "wt1_1" not in t.t2 and "wt1_1" not in t.t3


# ---------------------------------------------------------------- paths
def test_path_avoids_down_links():
    g = build_graph(make_config().topology)
    p = choose_path(g, "sdc1", "wt1_1")
    assert p[0] == "sdc1" and p[-1] == "wt1_1"
    assert p == ["sdc1", "s1", "s3", "l2", "wt1_1"]
    p2 = choose_path(g, "sdc1", "wt1_1", down={frozenset(("s1", "s3"))})
    assert frozenset(("s1", "s3")) not in {frozenset(x) for x in zip(p2, p2[1:])}
    assert choose_path(g, "sdc1", "wt1_1", down={frozenset(("s1", n)) for n in ("s2", "s3", "s4")}) is None


# ---------------------------------------------------------------- requests
def test_switch_up_installs_table_miss_and_controller_rule(ctl):
    actions = ctl.switch_up(1, now=0.1)
    assert any(a.priority == fl.PRIORITY_TABLE_MISS and a.out_ports == [fl.TO_CONTROLLER] for a in actions)
    assert not any(a.priority == fl.PRIORITY_PATH for a in actions)  # no path before a request


def test_visc_on_installs_both_directions_and_commands_sdc_turbine_owfcc(ctl):
    actions = ctl.packet_in(1, 4, frame(owfcc(ctl), request(wire.Command.VISC_ON, h=3.0, mask=1)), now=1.0)
    adds = [a for a in actions if isinstance(a, fl.FlowAdd)]
    outs = [decode_out(a) for a in actions if isinstance(a, fl.PacketOut) and not is_learn(a)]
    learn = [a for a in actions if isinstance(a, fl.PacketOut) and is_learn(a)]
    # the L2 switch learns at once that sdc1 is behind s3 (the OpenFlow switch in front of it)
    assert [(a.dpid, a.port) for a in learn] == [(3, ctl.graph.edges["s3", "l2"]["ports"]["s3"])] * 2
    assert packet.Packet(learn[0].data).get_protocol(ethernet.ethernet).src == ctl.config.topology.hosts["sdc1"].mac
    # path sdc1 - s1 - s3 - l2 - wt1_1: two OpenFlow switches, two directions each
    assert len(adds) == 4
    assert {a.dpid for a in adds} == {1, 3}
    matches = {(a.match["ipv4_src"], a.match["ipv4_dst"]) for a in adds}
    assert matches == {("10.0.0.21", "10.0.1.1"), ("10.0.1.1", "10.0.0.21")}
    s1_to_wt = next(a for a in adds if a.dpid == 1 and a.match["ipv4_dst"] == "10.0.1.1")
    assert s1_to_wt.out_ports == [ctl.graph.edges["s1", "s3"]["ports"]["s1"]]
    kinds = {(dst, port, m.type, m["status"] if m.type == wire.MsgType.REPLY else m["cmd"]) for dst, port, m in outs}
    assert ("10.0.0.21", wire.PORT_SDC, wire.MsgType.REQUEST, wire.Command.START_INSTANCE) in kinds
    assert ("10.0.1.1", wire.PORT_TURBINE, wire.MsgType.REQUEST, wire.Command.STREAM_START) in kinds
    assert ("10.0.0.10", wire.PORT_OWFCC, wire.MsgType.REPLY, wire.Status.OK) in kinds
    # access control: where the turbine's packets enter (s3, from the L2 switch), the flow also
    # matches its registered MAC and ingress port
    ingress = next(a for a in adds if a.dpid == 3 and a.match["ipv4_src"] == "10.0.1.1")
    assert ingress.match["eth_src"] == "02:00:00:00:01:01"
    assert ingress.match["in_port"] == ctl.graph.edges["s3", "l2"]["ports"]["s3"]
    start = next(m for d, _, m in outs if d == "10.0.0.21")
    assert start["h"] == pytest.approx(3.0) and start["mask"] == 1
    assert str(ctl.tables.t2["wt1_1"]) == "1/1" and str(ctl.tables.t3["wt1_1"]) == "1/1"


@pytest.mark.parametrize(
    ("config", "wt", "status"),
    [({}, "wt9_9", wire.Status.UNKNOWN_TURBINE), ({"visc_disabled": ["wt1_2"]}, "wt1_2", wire.Status.NOT_ENABLED)],
)
def test_refusals_are_answered_and_logged(config, wt, status):
    ctl = Controller(make_config(**config), now=0.0)
    actions = ctl.packet_in(1, 4, frame(owfcc(ctl), request(wire.Command.VISC_ON, wt=wt)), now=1.0)
    assert not [a for a in actions if isinstance(a, fl.FlowAdd)]
    (reply,) = [decode_out(a)[2] for a in actions if isinstance(a, fl.PacketOut) and not is_learn(a)]
    assert reply["status"] == status
    assert any(e["type"] == "request_refused" for e in ctl.take_events())


def test_no_path_refusal_after_links_fail(ctl):
    for other in (2, 3, 4):  # s1's three switch links
        port = next(p for (sw, p), key in ctl.port_links.items() if sw == "s1" and f"s{other}" in key)
        ctl.port_status(1, port, up=False, now=0.5)
    assert str(ctl.tables.t3["wt1_1"]) == "0/0"
    actions = ctl.packet_in(1, 4, frame(owfcc(ctl), request(wire.Command.VISC_ON)), now=1.0)
    (reply,) = [decode_out(a)[2] for a in actions if isinstance(a, fl.PacketOut) and not is_learn(a)]
    assert reply["status"] == wire.Status.NO_PATH


def test_visc_off_removes_flows_by_cookie(ctl):
    ctl.packet_in(1, 4, frame(owfcc(ctl), request(wire.Command.VISC_ON)), now=1.0)
    actions = ctl.packet_in(1, 4, frame(owfcc(ctl), request(wire.Command.VISC_OFF, req_id=8)), now=2.0)
    deletes = [a for a in actions if isinstance(a, fl.FlowDelete)]
    assert {d.dpid for d in deletes} == {1, 3}
    assert all(d.cookie == fl.turbine_cookie(101) for d in deletes)
    assert str(ctl.tables.t2["wt1_1"]) == "0/1" and ctl.tables.t3["wt1_1"].first == 0


def test_requests_from_other_hosts_and_garbage_are_dropped_and_counted(ctl):
    wt = ctl.config.topology.hosts["wt1_1"].model_dump()
    assert ctl.packet_in(3, 1, frame(wt, request(wire.Command.VISC_ON)), now=1.0) == []
    assert ctl.counters["drop_request_not_owfcc"] == 1
    assert ctl.packet_in(1, 4, frame(owfcc(ctl), b"\x00\x00\x00\x04" + b"\xff" * 7), now=1.0) == []
    assert ctl.counters["drop_malformed"] == 1
    # traffic between hosts with no installed path reaches the controller only to be dropped
    assert ctl.packet_in(3, 1, frame(wt, b"x" * 8, dst_ip="10.0.0.21", dst_port=wire.PORT_SDC), now=0.5) == []
    assert ctl.counters["drop_no_flow:10.0.1.1->10.0.0.21"] == 1


def test_ak_updates_t3_and_rejects_spoofed_source(ctl):
    ctl.packet_in(1, 4, frame(owfcc(ctl), request(wire.Command.VISC_ON)), now=1.0)
    wt = ctl.config.topology.hosts["wt1_1"].model_dump()
    ak0 = wire.encode(wire.MsgType.AK, {"wt": 101, "seq": 1, "ak": 0, "ctrl_rx": 0, "ctrl_age_ms": 50.0},
                      header=wire.Header(1, 0, 0))
    ctl.packet_in(3, 1, frame(wt, ak0), now=1.1)
    assert str(ctl.tables.t3["wt1_1"]) == "0/1"
    spoof = dict(wt, mac="02:00:00:00:09:09")
    ak1 = wire.encode(wire.MsgType.AK, {"wt": 101, "seq": 2, "ak": 1, "ctrl_rx": 5, "ctrl_age_ms": 0.5},
                      header=wire.Header(2, 0, 0))
    ctl.packet_in(3, 1, frame(spoof, ak1), now=1.2)
    assert ctl.counters["drop_ak_unregistered"] == 1 and str(ctl.tables.t3["wt1_1"]) == "0/1"
    ctl.packet_in(3, 1, frame(wt, ak1), now=1.2)
    assert str(ctl.tables.t3["wt1_1"]) == "1/1"


# ---------------------------------------------------------------- OpenFlow messages, no switch
def test_actions_become_serialisable_openflow13_messages(ctl):
    dp = SimpleNamespace(ofproto=ofproto_v1_3, ofproto_parser=ofproto_v1_3_parser, id=1)
    actions = ctl.switch_up(1, 0.0) + ctl.packet_in(1, 4, frame(owfcc(ctl), request(wire.Command.VISC_ON)), 1.0)
    actions += [fl.FlowDelete(1, fl.turbine_cookie(101))]
    kinds = set()
    for action in actions:
        for msg in to_messages(action, dp):
            msg.serialize()
            assert msg.buf[0] == ofproto_v1_3.OFP_VERSION
            kinds.add(type(msg).__name__)
    assert kinds == {"OFPFlowMod", "OFPPacketOut", "OFPBarrierRequest"}  # a barrier after each switch's flows
    miss = to_messages(fl.FlowAdd(1, 0, {}, (fl.Output(fl.TO_CONTROLLER),)), dp)[0]
    assert miss.instructions[0].actions[0].port == ofproto_v1_3.OFPP_CONTROLLER


def test_plug_and_unplug_on_the_turbines_access_port():
    desc = describe(topos["farm"](clusters=2, turbines=2))
    ctl = Controller(AppConfig.model_validate({"topology": desc, "backup_sdc": None}), now=0.0)
    owfcc_host = ctl.config.topology.hosts["owfcc"].model_dump()
    ctl.packet_in(1, 1, frame(owfcc_host, request(wire.Command.VISC_ON, wt="wt2_1")), now=1.0)
    h = ctl.config.topology.hosts["wt2_1"]
    actions = ctl.port_status(ctl.dpids[h.switch], h.port, up=False, now=2.0)
    assert "wt2_1" not in ctl.tables.t1 and "wt2_1" not in ctl.paths
    assert {a.cookie for a in actions if isinstance(a, fl.FlowDelete)} == {fl.turbine_cookie(201)}
    ctl.port_status(ctl.dpids[h.switch], h.port, up=True, now=3.0)
    assert ctl.tables.lookup("wt2_1").ip == "10.0.2.1" and str(ctl.tables.t2["wt2_1"]) == "0/1"
    assert [e["type"] for e in ctl.take_events()][-2:] == ["turbine_unplugged", "turbine_plugged"]
    refused = ctl.packet_in(1, 1, frame(owfcc_host, request(wire.Command.VISC_ON, wt="wt9_1")), now=4.0)
    assert decode_out(next(a for a in refused if isinstance(a, fl.PacketOut)))[2]["status"] == wire.Status.UNKNOWN_TURBINE
