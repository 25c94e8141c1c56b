"""Fast-failover protection: groups and detours deliver packets around any single failed link of
the path, checked by walking the installed flows through a small model of the data plane."""

from __future__ import annotations

import pytest

from sdn_app import flows as fl
from sdn_app.logic import Controller
from sdn_app.paths import link_key
from sdvisc import wire
from tests.unit.test_sdn_logic import frame, ingress, make_config, request
from topologies import topos
from topologies.base import describe


def switch_tables(actions):
    flows, groups = {}, {}
    for a in actions:
        if isinstance(a, fl.FlowAdd):
            flows.setdefault(a.dpid, []).append(a)
        elif isinstance(a, fl.GroupAdd):
            groups[(a.dpid, a.group_id)] = a
    return flows, groups


def matching_flow(ctl, flows, node: str, prev: str, src, dst):
    """The flow switch ``node`` applies to a UDP packet src → dst arriving from ``prev`` (None: table
    miss); returns (flow, in_port)."""
    in_port = ctl.graph.edges[node, prev]["ports"][node]
    cands = [f for f in flows.get(ctl.dpids[node], []) if f.match.get("ipv4_src") == src.ip
             and f.match.get("ipv4_dst") == dst.ip and f.match.get("in_port", in_port) == in_port]
    return (max(cands, key=lambda f: f.priority) if cands else None), in_port


def walk(ctl, flows, groups, src_host, dst_host, down: set, max_hops=20):
    """Follow a UDP packet src_host → dst_host through the flows; return the hosts/switches visited."""
    g = ctl.graph
    hosts = ctl.config.topology.hosts
    src, dst = hosts[src_host], hosts[dst_host]
    node, prev = src.switch, src_host
    visited = [src_host]
    for _ in range(max_hops):
        visited.append(node)
        if node == dst_host:
            return visited
        if link_key(prev, node) in down:
            return visited + ["<dropped: link down>"]
        if node not in ctl.dpids:  # the L2 switch: deliver to the host if attached, else to the other uplink
            nxt = dst_host if g.has_edge(node, dst_host) else next(n for n in g.neighbors(node)
                                                                    if n != prev and n in ctl.dpids
                                                                    and link_key(node, n) not in down)
            prev, node = node, nxt
            continue
        dpid = ctl.dpids[node]
        flow, in_port = matching_flow(ctl, flows, node, prev, src, dst)
        if flow is None:
            return visited + ["<table miss>"]
        out = None
        for act in flow.actions:
            if isinstance(act, fl.Group):
                grp = groups[(dpid, act.group_id)]
                for watch, acts in grp.buckets:
                    peer = next(n for n in g.neighbors(node) if g.edges[node, n]["ports"][node] == watch)
                    if link_key(node, peer) not in down:
                        out = acts[0].port
                        break
            elif isinstance(act, fl.Output):
                out = act.port
        if out is None:
            return visited + ["<no live bucket>"]
        if out == fl.IN_PORT:
            out = in_port
        nxt = next(n for n in g.neighbors(node) if g.edges[node, n]["ports"][node] == out)
        prev, node = node, nxt
    return visited + ["<loop>"]


@pytest.mark.parametrize(("topo", "params", "wt"), [
    ("paper", {"clusters": 1, "turbines": 2}, "wt1_1"),
    ("farm", {"clusters": 5, "turbines": 2}, "wt3_2"),
])
def test_every_protected_link_failure_is_bypassed_in_the_data_plane(topo, params, wt):
    desc = describe(topos[topo](**params))
    from sdvisc.config import AppConfig

    ctl = Controller(AppConfig.model_validate({"topology": desc, "backup_sdc": None, "fast_failover": True}), 0.0)
    owfcc = ctl.config.topology.hosts["owfcc"].model_dump()
    actions = ctl.packet_in(*ingress(ctl, "owfcc"), frame(owfcc, request(wire.Command.VISC_ON, wt=wt)), now=1.0)
    flows, groups = switch_tables(actions)
    assert groups, "fast-failover groups installed"
    path = ctl.paths[wt].path
    assert walk(ctl, flows, groups, "sdc1", wt, set())[-1] == wt
    assert walk(ctl, flows, groups, wt, "sdc1", set())[-1] == "sdc1"
    of_links = [link_key(a, b) for a, b in zip(path, path[1:]) if a in ctl.dpids and b in ctl.dpids]
    assert of_links
    for link in of_links:
        down = {link}
        assert walk(ctl, flows, groups, "sdc1", wt, down)[-1] == wt, (link, walk(ctl, flows, groups, "sdc1", wt, down))
        assert walk(ctl, flows, groups, wt, "sdc1", down)[-1] == "sdc1", (link, walk(ctl, flows, groups, wt, "sdc1", down))


def test_groups_are_deleted_with_the_path():
    ctl = Controller(make_config(backup_sdc=None, fast_failover=True), 0.0)
    owfcc = ctl.config.topology.hosts["owfcc"].model_dump()
    on = ctl.packet_in(*ingress(ctl, "owfcc"), frame(owfcc, request(wire.Command.VISC_ON)), now=1.0)
    added = {(a.dpid, a.group_id) for a in on if isinstance(a, fl.GroupAdd)}
    off = ctl.packet_in(*ingress(ctl, "owfcc"), frame(owfcc, request(wire.Command.VISC_OFF, req_id=9)), now=2.0)
    assert {(a.dpid, a.group_id) for a in off if isinstance(a, fl.GroupDelete)} == added


def test_group_messages_serialise():
    from types import SimpleNamespace

    from os_ken.ofproto import ofproto_v1_3, ofproto_v1_3_parser

    from sdn_app.ofmsg import to_messages

    dp = SimpleNamespace(ofproto=ofproto_v1_3, ofproto_parser=ofproto_v1_3_parser, id=1)
    for action in (fl.GroupAdd(1, 7, ((2, (fl.Output(2),)), (3, (fl.Output(fl.IN_PORT),)))), fl.GroupDelete(1, 7),
                   fl.FlowAdd(1, 100, {"eth_type": 0x800}, (fl.Group(7),))):
        (msg,) = to_messages(action, dp)
        msg.serialize()
        assert msg.buf[0] == ofproto_v1_3.OFP_VERSION


def test_l2_uplink_failure_teaches_the_l2_switch_the_other_uplink():
    ctl = Controller(make_config(backup_sdc=None, fast_failover=True), 0.0)
    owfcc = ctl.config.topology.hosts["owfcc"].model_dump()
    ctl.packet_in(*ingress(ctl, "owfcc"), frame(owfcc, request(wire.Command.VISC_ON)), now=1.0)
    assert ctl.paths["wt1_1"].path == ["sdc1", "s1", "s3", "l2", "wt1_1"]
    s3_l2 = ctl.graph.edges["s3", "l2"]["ports"]["s3"]
    actions = ctl.port_status(ctl.dpids["s3"], s3_l2, up=False, now=2.0)
    outs = [a for a in actions if isinstance(a, fl.PacketOut)]
    s4_l2 = (ctl.dpids["s4"], ctl.graph.edges["s4", "l2"]["ports"]["s4"])
    assert [(a.dpid, a.port) for a in outs] == [s4_l2, s4_l2]
    from os_ken.lib.packet import ethernet, packet

    # the SDC's MAC and the controller's virtual MAC (the turbine's AK must follow too)
    assert [packet.Packet(a.data).get_protocol(ethernet.ethernet).src for a in outs] == [
        ctl.config.topology.hosts["sdc1"].mac, ctl.config.controller_vmac]


def test_a_path_moved_by_dr_is_protected_again_when_the_failed_link_returns():
    """A DR around an L2 uplink computes the new path's detours while that uplink is down: the new
    path's own L2 uplink then has no detour. When the uplink comes back, the path is installed
    again with it, and a failure of the new uplink is bypassed in the data plane."""
    desc = describe(topos["paper"](clusters=2, turbines=2))
    from sdvisc.config import AppConfig

    ctl = Controller(AppConfig.model_validate({"topology": desc, "backup_sdc": None, "fast_failover": True}), 0.0)
    owfcc = ctl.config.topology.hosts["owfcc"].model_dump()
    ctl.packet_in(*ingress(ctl, "owfcc"), frame(owfcc, request(wire.Command.VISC_ON, wt="wt1_1")), now=1.0)
    assert ctl.paths["wt1_1"].path == ["sdc1", "s1", "s3", "l2", "wt1_1"]
    s3_port = ctl.graph.edges["s3", "l2"]["ports"]["s3"]
    ctl.port_status(ctl.dpids["s3"], s3_port, up=False, now=2.0)
    ctl.recovery.reroute("wt1_1", "dr", 2.05, None)
    moved = ctl.paths["wt1_1"]
    assert moved.path == ["sdc1", "s1", "s4", "l2", "wt1_1"]

    def bypassed(link) -> bool:
        flows, groups = switch_tables(ctl.paths["wt1_1"].installed)
        down = {link_key(*link)}
        return (walk(ctl, flows, groups, "sdc1", "wt1_1", down)[-1] == "wt1_1"
                and walk(ctl, flows, groups, "wt1_1", "sdc1", down)[-1] == "sdc1")

    assert not bypassed(("s4", "l2"))  # protected while s3-l2 was down: nothing to detour through
    actions = ctl.port_status(ctl.dpids["s3"], s3_port, up=True, now=2.3)
    assert ctl.paths["wt1_1"].path == moved.path and ctl.paths["wt1_1"].cookie != moved.cookie
    assert any(isinstance(a, fl.GroupAdd) for a in actions) and any(isinstance(a, fl.FlowDelete) for a in actions)
    assert bypassed(("s4", "l2"))
    assert [e["wt"] for e in ctl.take_events() if e["type"] == "reprotected"] == ["wt1_1"]
