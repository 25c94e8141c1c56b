"""One GTNET-SKT card serving several turbines from one IP, each on its own UDP port (issue 29):
the SDN app's paths, commands, DR and AK checks per turbine, and the SDC's answers to the port a
MEAS came from. Pure: no switch, no socket, an injected clock."""

from __future__ import annotations

import pytest
from os_ken.lib.packet import ethernet, ipv4, packet, udp
from os_ken.ofproto import ofproto_v1_3, ofproto_v1_3_parser
from pydantic import ValidationError

from sdn_app import flows as fl
from sdn_app.logic import Controller
from sdn_app.ofmsg import to_messages
from sdn_app.paths import path_links
from sdvisc import wire
from sdvisc.config import CONTROLLER_VIP, CONTROLLER_VMAC, AppConfig, HostInfo
from tests.unit.test_sdc_core import SDN_APP, ctrls, meas
from tests.unit.test_sdc_core import core as sdc_core
from tests.unit.test_sdc_core import request as sdc_request
from tests.unit.test_sdn_logic import decode_out, frame, is_learn, request
from topologies import topos
from topologies.base import describe

CARD_IP, CARD_MAC = "10.0.1.200", "02:00:00:00:01:c8"
CARD_SWITCH, CARD_PORT = "s3", 5  # an OpenFlow port of its own (s3's ports 1-4 are links)
PORTS = {"wt1_1": 50101, "wt1_2": 50102, "wt1_3": 50103}
HOLD = 0.040


def card_description() -> dict:
    """The paper network with its turbines replaced by one card on s3 serving wt1_1..wt1_3."""
    desc = describe(topos["paper"](clusters=1, turbines=2))
    desc["hosts"] = {n: h for n, h in desc["hosts"].items() if h["role"] != "turbine"}
    for name, port in PORTS.items():
        desc["hosts"][name] = {"ip": CARD_IP, "mac": CARD_MAC, "role": "turbine", "switch": CARD_SWITCH,
                               "port": CARD_PORT, "cluster": 1, "number": int(name[-1]), "udp_port": port}
    return desc


def controller(**kw) -> Controller:
    return Controller(AppConfig.model_validate({"topology": card_description(), **kw}), now=0.0)


def owfcc_says(ctl: Controller, cmd: wire.Command, wt: str, now: float, req_id: int = 7) -> list:
    owfcc = ctl.config.topology.hosts["owfcc"]
    return ctl.packet_in(ctl.dpids[owfcc.switch], owfcc.port, frame(owfcc.model_dump(), request(cmd, wt, req_id)),
                         now)


def card_frame(wt: str, payload: bytes) -> bytes:
    """A datagram of the card for the controller, from ``wt``'s UDP port."""
    pkt = packet.Packet()
    pkt.add_protocol(ethernet.ethernet(dst=CONTROLLER_VMAC, src=CARD_MAC, ethertype=0x0800))
    pkt.add_protocol(ipv4.ipv4(src=CARD_IP, dst=CONTROLLER_VIP, proto=17))
    pkt.add_protocol(udp.udp(src_port=PORTS.get(wt, 50100), dst_port=wire.PORT_CONTROLLER))
    pkt.add_protocol(payload)
    pkt.serialize()
    return bytes(pkt.data)


def ak_payload(wt: str, seq: int, value: int, age_s: float) -> bytes:
    return wire.encode(wire.MsgType.AK, {"wt": wire.turbine_id(*wire.parse_turbine(wt)), "seq": seq, "ak": value,
                                         "ctrl_rx": seq, "ctrl_age_ms": age_s * 1e3}, header=wire.Header(seq, 0, 0))


def ak(ctl: Controller, wt: str, seq: int, value: int, age_s: float, now: float, port: int = CARD_PORT) -> list:
    return ctl.packet_in(ctl.dpids[CARD_SWITCH], port, card_frame(wt, ak_payload(wt, seq, value, age_s)), now)


def flow_adds(actions: list) -> list[fl.FlowAdd]:
    return [a for a in actions if isinstance(a, fl.FlowAdd)]


def keys(flows) -> set:
    """What identifies a flow in a switch's table: switch, priority, match."""
    return {(f.dpid, f.priority, frozenset(f.match.items())) for f in flows}


def assert_flows_of(flows, wt: str) -> None:
    """Every flow of ``wt``'s path matches its endpoint: its UDP port as source on the way up, as
    destination on the way down."""
    assert flows
    for f in flows:
        if f.match.get("ipv4_src") == CARD_IP:
            assert f.match["udp_src"] == PORTS[wt] and "udp_dst" not in f.match, f
        else:
            assert f.match["ipv4_dst"] == CARD_IP and f.match["udp_dst"] == PORTS[wt] and "udp_src" not in f.match, f


def serializable(actions: list) -> None:
    """The matches are valid OpenFlow 1.3 (udp_src/udp_dst with their prerequisites)."""
    dp = type("Dp", (), {"ofproto": ofproto_v1_3, "ofproto_parser": ofproto_v1_3_parser, "id": 1})()
    for action in actions:
        if not isinstance(action, fl.PacketOut):
            for msg in to_messages(action, dp):
                msg.serialize()


# ---------------------------------------------------------------- the description
def test_a_turbine_host_carries_its_udp_port_and_the_default_is_the_turbine_port():
    desc = describe(topos["paper"](clusters=1, turbines=2))
    turbines = {n: h for n, h in desc["hosts"].items() if h["role"] == "turbine"}
    assert turbines and all(h["udp_port"] == wire.PORT_TURBINE for h in turbines.values())
    assert all("udp_port" not in h for h in desc["hosts"].values() if h["role"] != "turbine")
    AppConfig.model_validate({"topology": desc})
    entry = {"ip": CARD_IP, "mac": CARD_MAC, "role": "turbine", "switch": "s3", "port": 5}
    assert HostInfo.model_validate(entry).udp_port == wire.PORT_TURBINE == 50020
    assert HostInfo.model_validate({**entry, "udp_port": 50102}).udp_port == 50102
    for bad in (0, 65536):
        with pytest.raises(ValidationError, match="udp_port"):
            HostInfo.model_validate({**entry, "udp_port": bad})


def test_the_card_s_turbines_share_their_t1_address_but_not_their_port():
    ctl = controller()
    rows = {n: ctl.tables.t1[n] for n in PORTS}
    assert {(r.ip, r.mac, r.switch, r.port) for r in rows.values()} == {(CARD_IP, CARD_MAC, CARD_SWITCH, CARD_PORT)}
    assert {n: ctl.state.endpoint(n) for n in PORTS} == {n: (CARD_IP, p) for n, p in PORTS.items()}


# ---------------------------------------------------------------- paths
def test_one_host_per_turbine_its_flows_match_the_turbine_port():
    """The normal case: the same paths as ever, the flows now also match PORT_TURBINE."""
    ctl = Controller(AppConfig.model_validate({"topology": describe(topos["paper"](clusters=1, turbines=2)),
                                               "backup_sdc": None}), now=0.0)
    adds = flow_adds(owfcc_says(ctl, wire.Command.VISC_ON, "wt1_1", 1.0))
    assert len(adds) == 4 and ctl.paths["wt1_1"].path == ["sdc1", "s1", "s3", "l2", "wt1_1"]
    up = [a for a in adds if a.match["ipv4_src"] == "10.0.1.1"]
    down = [a for a in adds if a.match["ipv4_dst"] == "10.0.1.1"]
    assert len(up) == len(down) == 2
    assert all(a.match["udp_src"] == wire.PORT_TURBINE and "udp_dst" not in a.match for a in up)
    assert all(a.match["udp_dst"] == wire.PORT_TURBINE and "udp_src" not in a.match for a in down)


@pytest.mark.parametrize("options", [{}, {"backup_sdc": None}, {"fast_failover": True},
                                     {"duplicate_paths": True, "backup_sdc": None}],
                         ids=["mirror", "plain", "fast_failover", "duplicate_paths"])
def test_two_turbines_of_one_card_get_two_independent_paths(options):
    ctl = controller(**options)
    first = owfcc_says(ctl, wire.Command.VISC_ON, "wt1_1", 1.0)
    second = owfcc_says(ctl, wire.Command.VISC_ON, "wt1_2", 1.1, req_id=8)
    assert set(ctl.paths) == {"wt1_1", "wt1_2"}
    assert not [a for a in first + second if isinstance(a, fl.FlowDelete)], "installing one never deletes"
    for wt, actions in (("wt1_1", first), ("wt1_2", second)):
        adds = flow_adds(actions)
        assert_flows_of(adds, wt)
        assert {a.cookie for a in adds} == {fl.turbine_cookie(wire.turbine_id(1, int(wt[-1])))}
        serializable(actions)
        # the card's ingress: its registered port and MAC, and the turbine's UDP port
        (entry,) = [a for a in adds if a.dpid == ctl.dpids[CARD_SWITCH] and a.match.get("ipv4_src") == CARD_IP
                    and a.priority == fl.PRIORITY_PATH and a.match["ipv4_dst"] == "10.0.0.21"]
        assert (entry.match["in_port"], entry.match["eth_src"], entry.match["udp_src"]) == (CARD_PORT, CARD_MAC,
                                                                                          PORTS[wt])
    assert not keys(flow_adds(first)) & keys(flow_adds(second)), "no flow of one overwrites the other's"
    # the same path, the same switches; only the UDP port tells the flows apart
    assert ctl.paths["wt1_1"].path[1:-1] == ctl.paths["wt1_2"].path[1:-1]
    strip = {(k[0], k[1], frozenset((f, v) for f, v in k[2] if f not in ("udp_src", "udp_dst")))
             for k in keys(flow_adds(first))}
    assert strip == {(k[0], k[1], frozenset((f, v) for f, v in k[2] if f not in ("udp_src", "udp_dst")))
                     for k in keys(flow_adds(second))}
    groups = [{(g.dpid, g.group_id) for g in a if isinstance(g, fl.GroupAdd)} for a in (first, second)]
    assert not groups[0] & groups[1]
    if options.get("fast_failover"):
        assert groups[0] and groups[1]
    if options.get("duplicate_paths"):
        assert ctl.paths["wt1_1"].second_leg and ctl.paths["wt1_2"].second_leg


def test_the_mirror_to_the_backup_copies_each_turbine_by_its_port():
    ctl = controller()
    actions = owfcc_says(ctl, wire.Command.VISC_ON, "wt1_2", 1.0)
    mirror = [a for a in flow_adds(actions) if any(isinstance(x, fl.SetField) and x.value == "10.0.0.22"
                                                   for x in a.actions) or a.match.get("ipv4_dst") == "10.0.0.22"]
    assert mirror and all(a.match["udp_src"] == PORTS["wt1_2"] for a in mirror)


def test_a_substitute_sdc_serves_each_turbine_by_its_port():
    ctl = controller()
    owfcc_says(ctl, wire.Command.VISC_ON, "wt1_1", 1.0)
    owfcc_says(ctl, wire.Command.VISC_ON, "wt1_2", 1.1, req_id=8)
    kept = list(ctl.paths["wt1_1"].installed)
    actions = ctl.routing.install("wt1_2", "sdc2", ctl.state.path_to("sdc2", "wt1_2"), 2.0)
    adds = flow_adds(actions)
    assert_flows_of(adds, "wt1_2")
    assert any(a.match.get("ipv4_src") == "10.0.0.22" for a in adds), "the substitute's answers, rewritten"
    assert {d.cookie for d in actions if isinstance(d, fl.FlowDelete)} == {fl.turbine_cookie(102)}
    assert ctl.paths["wt1_1"].installed == kept and ctl.paths["wt1_1"].sdc == "sdc1"


# ---------------------------------------------------------------- commands
def test_stream_start_and_stop_go_to_the_turbine_s_own_port():
    ctl = controller(backup_sdc=None)
    on = owfcc_says(ctl, wire.Command.VISC_ON, "wt1_2", 1.0)
    outs = {(dst, port, m.type, m["cmd"] if m.type == wire.MsgType.REQUEST else m["status"], m["wt"])
            for dst, port, m in (decode_out(a) for a in on if isinstance(a, fl.PacketOut) and not is_learn(a))}
    assert (CARD_IP, 50102, wire.MsgType.REQUEST, wire.Command.STREAM_START, 102) in outs
    assert ("10.0.0.21", wire.PORT_SDC, wire.MsgType.REQUEST, wire.Command.START_INSTANCE, 102) in outs
    assert not [o for o in outs if o[0] == CARD_IP and o[1] != 50102]
    again = [decode_out(a) for a in ctl.messenger.reengage("wt1_2", "sdc1", 2.0)]
    assert (CARD_IP, 50102, wire.Command.STREAM_START) in {(d, p, m["cmd"]) for d, p, m in again}
    off = owfcc_says(ctl, wire.Command.VISC_OFF, "wt1_2", 3.0, req_id=9)
    stops = [(d, p) for d, p, m in (decode_out(a) for a in off if isinstance(a, fl.PacketOut) and not is_learn(a))
             if m.type == wire.MsgType.REQUEST and m["cmd"] == wire.Command.STREAM_STOP]
    assert stops == [(CARD_IP, 50102)]


def test_switching_one_turbine_off_leaves_the_other_s_flows():
    ctl = controller()
    owfcc_says(ctl, wire.Command.VISC_ON, "wt1_1", 1.0)
    owfcc_says(ctl, wire.Command.VISC_ON, "wt1_2", 1.1, req_id=8)
    kept = ctl.paths["wt1_2"]
    off = owfcc_says(ctl, wire.Command.VISC_OFF, "wt1_1", 2.0, req_id=9)
    assert {d.cookie for d in off if isinstance(d, fl.FlowDelete)} == {fl.turbine_cookie(101)}
    assert not flow_adds(off) and set(ctl.paths) == {"wt1_2"} and ctl.paths["wt1_2"] is kept
    assert str(ctl.tables.t2["wt1_2"]) == "1/1" and str(ctl.tables.t2["wt1_1"]) == "0/1"


# ---------------------------------------------------------------- DR and AK
def test_a_dr_on_one_turbine_of_the_card_reroutes_only_that_one():
    ctl = controller(backup_sdc=None)
    owfcc_says(ctl, wire.Command.VISC_ON, "wt1_1", 1.0)
    owfcc_says(ctl, wire.Command.VISC_ON, "wt1_2", 1.0, req_id=8)
    other, other_flows = ctl.paths["wt1_2"], list(ctl.paths["wt1_2"].installed)
    old = ctl.paths["wt1_1"].path
    for wt in PORTS:
        if wt in ctl.paths:
            ak(ctl, wt, 1, 1, 0.0005, 1.5)
    ak(ctl, "wt1_1", 2, 0, 0.012, 1.52)  # wt1_1's control packets stopped at 1.508; wt1_2's still arrive
    ak(ctl, "wt1_2", 2, 1, 0.0005, 1.52)
    ak(ctl, "wt1_1", 3, 0, 0.032, 1.54)
    ak(ctl, "wt1_2", 3, 1, 0.0005, 1.54)
    assert ctl.tick(1.545) == []
    actions = ak(ctl, "wt1_1", 4, 0, HOLD + 0.001, 1.508 + HOLD + 0.001)  # AK = 0 for longer than the hold
    dr = [e for e in ctl.take_events() if e["type"] == "dr"]
    assert [e["wt"] for e in dr] == ["wt1_1"]
    assert {d.cookie for d in actions if isinstance(d, fl.FlowDelete)} == {fl.turbine_cookie(101)}
    adds = flow_adds(actions)
    assert {a.cookie for a in adds} == {fl.turbine_cookie(101, 1)}
    assert_flows_of(adds, "wt1_1")
    new = ctl.paths["wt1_1"].path
    assert not set(path_links(new)[1:-1]) & set(path_links(old)[1:-1]), "link-disjoint between the switches"
    assert ctl.paths["wt1_2"] is other and other.installed == other_flows and other.reroutes == 0
    assert not keys(adds) & keys(other_flows)
    ak(ctl, "wt1_2", 4, 1, 0.0005, 1.55)
    assert ctl.tick(1.555) == [] and ctl.paths["wt1_2"].path[:-1] == old[:-1]


def test_an_ak_of_a_card_turbine_is_checked_against_that_turbine_s_entry():
    ctl = controller(backup_sdc=None)
    owfcc_says(ctl, wire.Command.VISC_ON, "wt1_2", 1.0)
    c = ctl.counters
    assert ak(ctl, "wt1_2", 1, 1, 0.0005, 1.5) == [] and c["ak_rx"] == 1
    assert ctl.dr.tracks["wt1_2"].seq == 1 and "wt1_1" not in ctl.dr.tracks
    ak(ctl, "wt1_3", 1, 1, 0.0005, 1.51)  # the card's, but not in ViSC
    assert c["ak_not_in_visc"] == 1
    ak(ctl, "wt1_9", 1, 1, 0.0005, 1.52)  # a turbine the card does not serve
    ak(ctl, "wt1_2", 2, 1, 0.0005, 1.53, port=1)  # the right claim from another port
    assert (c["drop_ak_unregistered"], c["drop_ak_wrong_port"], c["ak_rx"]) == (1, 1, 1)
    assert ctl.dr.tracks["wt1_2"].seq == 1


def test_the_intake_socket_takes_the_card_s_aks_by_its_one_address():
    desc = card_description()
    desc["intake_ports"] = {"s1": 9, "s3": 9}
    ctl = Controller(AppConfig.model_validate({"topology": desc, "backup_sdc": None,
                                               "intake_socket": {"netns_pid": None}}), now=0.0)
    intake = [a for a in ctl.switch_up(ctl.dpids["s3"], 0.1) if a.priority == fl.PRIORITY_INTAKE]
    assert [(a.match["in_port"], a.match["eth_src"], a.match["ipv4_src"]) for a in intake] == [
        (CARD_PORT, CARD_MAC, CARD_IP)]
    owfcc_says(ctl, wire.Command.VISC_ON, "wt1_2", 1.0)
    ctl.delivered([(CARD_IP, ak_payload("wt1_2", 1, 1, 0.0005)), (CARD_IP, ak_payload("wt1_9", 1, 1, 0.0005))], 1.5)
    assert (ctl.counters["ak_rx"], ctl.counters["drop_ak_unregistered"]) == (1, 1)


def test_unplugging_the_card_takes_all_its_turbines_along():
    ctl = controller(backup_sdc=None)
    owfcc_says(ctl, wire.Command.VISC_ON, "wt1_1", 1.0)
    owfcc_says(ctl, wire.Command.VISC_ON, "wt1_2", 1.0, req_id=8)
    actions = ctl.port_status(ctl.dpids[CARD_SWITCH], CARD_PORT, up=False, now=2.0)
    assert {d.cookie for d in actions if isinstance(d, fl.FlowDelete)} == {fl.turbine_cookie(101),
                                                                             fl.turbine_cookie(102)}
    assert not set(PORTS) & set(ctl.tables.t1) and not ctl.paths
    ctl.port_status(ctl.dpids[CARD_SWITCH], CARD_PORT, up=True, now=3.0)
    assert set(PORTS) <= set(ctl.tables.t1) and ctl.tables.t1["wt1_3"].udp_port == 50103
    assert sorted(e["wt"] for e in ctl.take_events() if e["type"] == "turbine_plugged") == sorted(PORTS)


# ---------------------------------------------------------------- the SDC
def test_the_sdc_answers_each_meas_at_the_port_it_came_from(tmp_path):
    c = sdc_core(tmp_path)
    c.handle([(sdc_request(wire.Command.START_INSTANCE, wt, req_id=wt), SDN_APP) for wt in (101, 102)], 10.0)
    out = c.handle([(meas(101, 1), (CARD_IP, 50101)), (meas(102, 1), (CARD_IP, 50102))], 10.5)
    assert [(m["wt"], addr) for m, (_, addr, _) in zip(ctrls(out), out.sends)] == [(101, (CARD_IP, 50101)),
                                                                                  (102, (CARD_IP, 50102))]
    out = c.handle([(meas(102, 2), (CARD_IP, 50102))], 10.6)
    assert [addr for _, addr, _ in out.sends] == [(CARD_IP, 50102)]
    out = c.handle([(meas(101, 2), ("10.0.1.1", wire.PORT_TURBINE))], 10.7)  # one host, one turbine: as ever
    assert [addr for _, addr, _ in out.sends] == [("10.0.1.1", wire.PORT_TURBINE)]


def test_a_backup_that_took_over_answers_the_mirrored_turbine_s_port(tmp_path):
    c = sdc_core(tmp_path, role="backup")
    assert c.backup
    out = c.handle([(meas(102, seq), (CARD_IP, 50102)) for seq in (1, 2)], 10.0)  # mirrored: followed only
    assert out.sends == [] and c.instances[102].counts["meas_tracked"] == 2
    c.handle([(sdc_request(wire.Command.TAKEOVER, 102), SDN_APP)], 10.1)
    out = c.handle([(meas(102, 3), (CARD_IP, 50102))], 10.2)  # the switches rewrote only the destination
    assert [(m["wt"], addr) for m, (_, addr, _) in zip(ctrls(out), out.sends)] == [(102, (CARD_IP, 50102))]
