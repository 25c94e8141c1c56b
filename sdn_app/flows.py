"""Pure descriptions of what the app asks switches to do, and builders for them.

Decisions in :mod:`sdn_app.logic` return lists of these; :mod:`sdn_app.ofmsg` turns them into
OpenFlow 1.3 messages. Nothing here talks to a switch.
"""

from __future__ import annotations

from dataclasses import dataclass, field

ETH_TYPE_IPV4 = 0x0800
ETH_TYPE_IPV6 = 0x86DD
IP_PROTO_UDP = 17

PRIORITY_TABLE_MISS = 0
PRIORITY_DROP_NOISE = 10
PRIORITY_TO_CONTROLLER = 50
PRIORITY_INTAKE = 60
PRIORITY_PATH = 100

COOKIE_BASE = 0x5D000000  # flows of a turbine's path carry COOKIE_BASE + turbine id


@dataclass(frozen=True)
class Output:
    port: int  # TO_CONTROLLER for the controller


@dataclass(frozen=True)
class SetField:
    name: str  # an OpenFlow 1.3 OXM field name, e.g. "ipv4_dst", "eth_dst"
    value: object


@dataclass(frozen=True)
class FlowAdd:
    """Add (or overwrite) a flow; ``actions`` empty means drop."""

    dpid: int
    priority: int
    match: dict
    actions: tuple = ()
    cookie: int = 0

    @property
    def out_ports(self) -> list[int]:
        return [a.port for a in self.actions if isinstance(a, Output)]


@dataclass(frozen=True)
class FlowDelete:
    dpid: int
    cookie: int


@dataclass(frozen=True)
class PacketOut:
    dpid: int
    port: int
    data: bytes = field(repr=False)


TO_CONTROLLER = -1
IN_PORT = -2  # OpenFlow's OFPP_IN_PORT: send back out of the port the packet came in on
PRIORITY_DETOUR = 110


@dataclass(frozen=True)
class Group:
    """Flow action: process the packet in group ``group_id``."""

    group_id: int


@dataclass(frozen=True)
class GroupAdd:
    """A fast-failover group: the first bucket whose watch port is live forwards the packet."""

    dpid: int
    group_id: int
    buckets: tuple  # ((watch_port, (actions...)), ...)


@dataclass(frozen=True)
class GroupDelete:
    dpid: int
    group_id: int


@dataclass(frozen=True)
class Barrier:
    """An OpenFlow barrier after a path's changes on one switch: its reply says the switch has
    them (``tag`` names the path version, see :mod:`sdn_app.routing`)."""

    dpid: int
    tag: str


def base_flows(dpid: int, controller_vip: str) -> list[FlowAdd]:
    """What every OpenFlow switch gets on connect: table miss and the virtual controller IP to
    the controller (so unrequested traffic is seen, counted and dropped, never forwarded), IPv6
    noise dropped."""
    to_controller = (Output(TO_CONTROLLER),)
    return [
        FlowAdd(dpid, PRIORITY_TABLE_MISS, {}, to_controller),
        FlowAdd(dpid, PRIORITY_DROP_NOISE, {"eth_type": ETH_TYPE_IPV6}, ()),
        FlowAdd(dpid, PRIORITY_TO_CONTROLLER, {"eth_type": ETH_TYPE_IPV4, "ipv4_dst": controller_vip}, to_controller),
    ]


def intake_flows(dpid: int, intake_port: int, senders: list[tuple[int, str, str]], controller_vip: str,
                 controller_udp_port: int) -> list[FlowAdd]:
    """Datagrams for the controller from the hosts on this switch, each matched on its own port,
    MAC and IP, out of ``intake_port`` to the controller's socket instead of a packet-in (``senders``:
    (port, mac, ip) of each host). Anything else for the controller (a wrong port, a forged address)
    still meets :func:`base_flows`' packet-in rule and is counted and dropped there."""
    return [FlowAdd(dpid, PRIORITY_INTAKE, {"in_port": port, "eth_src": mac, "eth_type": ETH_TYPE_IPV4, "ipv4_src": ip,
                                            "ipv4_dst": controller_vip, "ip_proto": IP_PROTO_UDP,
                                            "udp_dst": controller_udp_port}, (Output(intake_port),))
            for port, mac, ip in senders]


def udp_match(src_ip: str, dst_ip: str, *, udp_src: int | None = None, udp_dst: int | None = None) -> dict:
    """UDP from ``src_ip`` to ``dst_ip``; with ``udp_src``/``udp_dst`` also those UDP ports."""
    match = {"eth_type": ETH_TYPE_IPV4, "ip_proto": IP_PROTO_UDP, "ipv4_src": src_ip, "ipv4_dst": dst_ip}
    if udp_src is not None:
        match["udp_src"] = udp_src
    if udp_dst is not None:
        match["udp_dst"] = udp_dst
    return match


Endpoint = tuple[str, int]
"""A turbine's endpoint: (IP, UDP port). A GTNET-SKT card serves several turbines from one IP, one
port each, so a turbine's flows match its port too and two turbines of one card get independent
flows."""


def from_turbine(wt: Endpoint, dst_ip: str) -> dict:
    """The turbine's packets (from its endpoint) to ``dst_ip``."""
    return udp_match(wt[0], dst_ip, udp_src=wt[1])


def to_turbine(src_ip: str, wt: Endpoint) -> dict:
    """Packets from ``src_ip`` to the turbine's endpoint."""
    return udp_match(src_ip, wt[0], udp_dst=wt[1])


def path_flows(hops: list[tuple[str, int, int]], dpids: dict[str, int], sdc_ip: str, wt: Endpoint,
               cookie: int) -> list[FlowAdd]:
    """Both directions of a path between an SDC and a turbine's endpoint, given as (switch, port
    toward the SDC, port toward the turbine) hops."""
    flows = []
    for switch, toward_sdc, toward_wt in hops:
        dpid = dpids[switch]
        flows.append(FlowAdd(dpid, PRIORITY_PATH, to_turbine(sdc_ip, wt), (Output(toward_wt),), cookie))
        flows.append(FlowAdd(dpid, PRIORITY_PATH, from_turbine(wt, sdc_ip), (Output(toward_sdc),), cookie))
    return flows


def substitute_path_flows(hops: list[tuple[str, int, int]], dpids: dict[str, int], sub: dict, wt: Endpoint,
                          addressed: dict, cookie: int) -> list[FlowAdd]:
    """Flows that let a turbine keep addressing ``addressed`` (ip, mac) while ``sub`` (ip, mac) serves it.

    ``hops`` run from the substitute's side (index 0, next to ``sub``) to the turbine. Toward the
    substitute, packets to the addressed IP are forwarded and, on the last switch, rewritten to the
    substitute; the substitute's answers are rewritten on its switch to come from the addressed
    address, then forwarded like the addressed SDC's own packets.
    """
    flows = []
    for i, (switch, toward_sub, toward_wt) in enumerate(hops):
        dpid = dpids[switch]
        up = (Output(toward_sub),)
        down_match = to_turbine(addressed["ip"], wt)
        if i == 0:
            up = (SetField("eth_dst", sub["mac"]), SetField("ipv4_dst", sub["ip"]), Output(toward_sub))
            down_match = to_turbine(sub["ip"], wt)
            down = (SetField("eth_src", addressed["mac"]), SetField("ipv4_src", addressed["ip"]), Output(toward_wt))
        else:
            down = (Output(toward_wt),)
        flows.append(FlowAdd(dpid, PRIORITY_PATH, from_turbine(wt, addressed["ip"]), up, cookie))
        flows.append(FlowAdd(dpid, PRIORITY_PATH, down_match, down, cookie))
    return flows


def mirror_flows(hops_to_mirror: list[tuple[str, int, int]], dpids: dict[str, int], primary_flow: FlowAdd,
                 mirror: dict, wt: Endpoint, cookie: int) -> list[FlowAdd]:
    """Copy a turbine's packets to a warm standby ``mirror`` (ip, mac).

    ``primary_flow`` is the upstream flow on the switch where the copy leaves (it keeps its own
    output and gains a rewritten copy toward the mirror); ``hops_to_mirror`` run from that switch
    to the mirror host.
    """
    first_switch, _, first_out = hops_to_mirror[0]
    copy = (SetField("eth_dst", mirror["mac"]), SetField("ipv4_dst", mirror["ip"]), Output(first_out))
    flows = [FlowAdd(primary_flow.dpid, primary_flow.priority, primary_flow.match, primary_flow.actions + copy,
                     cookie)]
    for switch, _, toward_mirror in hops_to_mirror[1:]:
        flows.append(FlowAdd(dpids[switch], PRIORITY_PATH, from_turbine(wt, mirror["ip"]), (Output(toward_mirror),),
                             cookie))
    return flows


COOKIE_MASK_TURBINE = 0xFFFFFFFF  # low 32 bits: base + turbine id; bits 32..47: path version


def turbine_cookie(wid: int, version: int = 0) -> int:
    """Cookie of a turbine's path flows; each reroute installs a new ``version`` first and then
    deletes the old one (make before break)."""
    return ((version & 0xFFFF) << 32) | (COOKIE_BASE + wid)
