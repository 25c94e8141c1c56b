"""1+1 duplication (``duplicate_paths``): every packet reaches the other end twice over two
node-disjoint legs, and once whatever single link or switch between the legs' ends fails — with
no flow changed. Checked by following every copy through the installed flows (a model of the data
plane that forwards on every output action, as a switch does)."""

from __future__ import annotations

import pytest

from sdn_app import flows as fl
from sdn_app.duplication import second_leg, segment
from sdn_app.logic import Controller
from sdn_app.paths import link_key, path_links
from sdvisc import wire
from sdvisc.config import AppConfig
from tests.unit.test_sdn_fast_failover import matching_flow, switch_tables
from tests.unit.test_sdn_logic import frame, ingress, request
from topologies import topos
from topologies.base import describe


def copies(ctl, flows, groups, src_host, dst_host, down: set, max_hops=30) -> int:
    """How many copies of one UDP packet src_host → dst_host reach dst_host (every output action is
    followed; an L2 switch delivers to an attached host, else to the uplink it learned: where the
    SDC's packets of the turbine's installed path come from, or the first live one if that is down)."""
    g = ctl.graph
    hosts = ctl.config.topology.hosts
    src, dst = hosts[src_host], hosts[dst_host]
    arrived = 0
    frontier = [(src.switch, src_host, 0)]
    while frontier:
        node, prev, n = frontier.pop()
        assert n < max_hops, "a forwarding loop"
        if link_key(prev, node) in down:
            continue
        if node == dst_host:
            arrived += 1
            continue
        if node not in ctl.dpids:
            learned = [p.path[p.path.index(node) - 1] for p in ctl.paths.values() if node in p.path]
            uplinks = [x for x in learned + sorted(g.neighbors(node))
                       if x != prev and x in ctl.dpids and link_key(node, x) not in down]
            nxt = dst_host if g.has_edge(node, dst_host) else next(iter(uplinks), None)
            if nxt is not None:
                frontier.append((nxt, node, n + 1))
            continue
        dpid = ctl.dpids[node]
        flow, in_port = matching_flow(ctl, flows, node, prev, src, dst)
        if flow is None:
            continue  # table miss: to the controller, not forwarded
        outs = []
        for act in flow.actions:
            if isinstance(act, fl.SetField):
                break  # what follows is a rewritten copy (to the backup SDC): another packet
            if isinstance(act, fl.Output):
                outs.append(act.port)
            elif isinstance(act, fl.Group):
                for watch, acts in groups[(dpid, act.group_id)].buckets:
                    peer = next(x for x in g.neighbors(node) if g.edges[node, x]["ports"][node] == watch)
                    if link_key(node, peer) not in down:
                        outs.append(acts[0].port)
                        break
        for out in outs:
            out = in_port if out == fl.IN_PORT else out
            nxt = next(x for x in g.neighbors(node) if g.edges[node, x]["ports"][node] == out)
            frontier.append((nxt, node, n + 1))
    return arrived


def controller(topo: str, fast_failover: bool = False, backup_sdc: str | None = None, **params) -> Controller:
    desc = describe(topos[topo](**params))
    return Controller(AppConfig.model_validate({"topology": desc, "backup_sdc": backup_sdc, "duplicate_paths": True,
                                                "fast_failover": fast_failover}), 0.0)


def visc_on(ctl: Controller, wt: str, now: float = 1.0) -> list:
    owfcc = ctl.config.topology.hosts["owfcc"].model_dump()
    return ctl.packet_in(*ingress(ctl, "owfcc"), frame(owfcc, request(wire.Command.VISC_ON, wt=wt)), now=now)


CASES = [("paper", {"clusters": 2, "turbines": 2}, "wt1_1"),
         ("farm", {"clusters": 5, "turbines": 2, "layout": "compact"}, "wt1_2"),
         ("farm", {"clusters": 5, "turbines": 2, "layout": "compact"}, "wt3_2"),
         ("farm", {"clusters": 5, "turbines": 2, "layout": "compact"}, "wt5_1"),
         ("farm", {"clusters": 3, "turbines": 4, "layout": "tower"}, "wt2_3")]


@pytest.mark.parametrize(("topo", "params", "wt"), CASES)
@pytest.mark.parametrize(("fast_failover", "backup_sdc"), [(False, None), (True, None), (True, "sdc2")])
def test_every_single_failure_between_the_legs_ends_costs_no_packet(topo, params, wt, fast_failover, backup_sdc):
    """With fast failover as well, and with the measurements mirrored to a backup SDC."""
    ctl = controller(topo, fast_failover, backup_sdc, **params)
    flows, groups = switch_tables(visc_on(ctl, wt))
    active = ctl.paths[wt]
    path, leg = active.path, active.second_leg
    assert leg is not None and ctl.counters["duplicated"] == 1
    i_a, i_b = segment(path, ctl.dpids)
    assert (leg[0], leg[-1]) == (path[i_a], path[i_b])
    assert not set(leg[1:-1]) & set(path), "node-disjoint legs"
    assert all(n in ctl.dpids for n in leg), "only OpenFlow switches carry the copy"
    for a, b in (("sdc1", wt), (wt, "sdc1")):
        assert copies(ctl, flows, groups, a, b, set()) == 2, (a, b)
    between = set(path_links(path[i_a:i_b + 1])) | set(path_links(leg))
    switches = set(path[i_a + 1:i_b]) | set(leg[1:-1])
    failures = [{link} for link in between] + [{link_key(s, x) for x in ctl.graph.neighbors(s)} for s in switches]
    assert len(failures) >= 4
    for down in failures:
        for a, b in (("sdc1", wt), (wt, "sdc1")):
            assert copies(ctl, flows, groups, a, b, down) >= 1, (a, b, sorted(map(sorted, down)))


def test_the_paper_legs_merge_before_the_l2_switch():
    """Behind a learning switch only one uplink may carry the SDC's packets (else its MAC entry moves
    with every packet): the legs end at the last OpenFlow switch, s3."""
    ctl = controller("paper", clusters=1, turbines=2)
    visc_on(ctl, "wt1_1")
    assert ctl.paths["wt1_1"].path == ["sdc1", "s1", "s3", "l2", "wt1_1"]
    assert ctl.paths["wt1_1"].second_leg == ["s1", "s2", "s3"]


def test_without_a_disjoint_leg_the_path_stays_single_and_says_so():
    ctl = controller("farm", clusters=3, turbines=2, layout="compact")
    ctl.state.down_links.add(link_key("sub1", "sub2"))  # the ring is a line now
    actions = visc_on(ctl, "wt2_1")
    assert ctl.paths["wt2_1"].second_leg is None
    assert ctl.counters["not_duplicated"] == 1
    assert [e for e in ctl.state.events if e["type"] == "not_duplicated"]
    flows, groups = switch_tables(actions)
    assert copies(ctl, flows, groups, "sdc1", "wt2_1", set()) == 1


def test_a_failed_leg_is_replaced_without_a_dr():
    """s1–s3 fails under wt1_1 (paper): its packets keep arriving over s1–s2–s3; the app pairs the
    path again around the failure (two copies again with the link down) and arms no DR."""
    ctl = controller("paper", clusters=1, turbines=2)
    visc_on(ctl, "wt1_1")
    track = ctl.dr.track("wt1_1")
    started = track.t_started
    port = ctl.graph.edges["s1", "s3"]["ports"]["s1"]
    actions = ctl.port_status(ctl.dpids["s1"], port, up=False, now=2.0)
    active = ctl.paths["wt1_1"]
    assert active.path == ["sdc1", "s1", "s4", "l2", "wt1_1"] and active.second_leg == ["s1", "s2", "s3", "s4"]
    assert active.reroutes == 1 and ctl.counters["pairs_repaired"] == 1
    assert [e["type"] for e in ctl.state.events if e["type"] in ("pair_repaired", "dr")] == ["pair_repaired"]
    assert ctl.dr.track("wt1_1").t_started == started, "the DR hold is not restarted by a hitless repair"
    down = {link_key("s1", "s3")}
    flows, groups = switch_tables(active.installed)
    for a, b in (("sdc1", "wt1_1"), ("wt1_1", "sdc1")):
        assert copies(ctl, flows, groups, a, b, down) == 2
    assert any(isinstance(a, fl.FlowDelete) for a in actions), "the old version is removed (make before break)"


def test_a_single_leg_path_is_left_to_dr_when_its_link_fails():
    """Without a second leg a failure loses the packets: no hitless re-pairing (the DR, or fast
    failover, repairs it, with the hold armed from the new path as after any reroute)."""
    ctl = controller("paper", clusters=1, turbines=2)
    ctl.state.down_links |= {link_key("s2", "s3"), link_key("s3", "s4")}  # s3 only via s1-s3: no leg
    visc_on(ctl, "wt1_1")
    assert ctl.paths["wt1_1"].path == ["sdc1", "s1", "s3", "l2", "wt1_1"] and ctl.paths["wt1_1"].second_leg is None
    port = ctl.graph.edges["s3", "l2"]["ports"]["s3"]
    ctl.port_status(ctl.dpids["s3"], port, up=False, now=2.0)  # another path exists: s1-s4-l2
    assert ctl.counters["pairs_repaired"] == 0 and ctl.paths["wt1_1"].reroutes == 0


def test_duplicated_flows_serialise_with_two_outputs():
    from types import SimpleNamespace

    from os_ken.ofproto import ofproto_v1_3, ofproto_v1_3_parser

    from sdn_app.ofmsg import to_messages

    ctl = controller("paper", clusters=1, turbines=2)
    flows = [a for a in visc_on(ctl, "wt1_1") if isinstance(a, fl.FlowAdd) and len(a.out_ports) == 2]
    assert len(flows) == 2  # s1 toward the turbine, s3 toward the SDC
    dp = SimpleNamespace(ofproto=ofproto_v1_3, ofproto_parser=ofproto_v1_3_parser, id=1)
    for f in flows:
        (msg,) = to_messages(f, dp)
        msg.serialize()
        assert len(msg.instructions[0].actions) == 2


def test_second_leg_is_none_with_one_openflow_switch():
    ctl = controller("farm", clusters=2, turbines=2, layout="compact")
    assert second_leg(ctl.state.path_to, ctl.dpids, ["sdc1", "sub1", "owfcc"]) is None
