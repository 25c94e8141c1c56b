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
PRIORITY_PATH = 100

COOKIE_BASE = 0x5D000000  # flows of a turbine's path carry COOKIE_BASE + turbine id


@dataclass(frozen=True)
class FlowAdd:
    dpid: int
    priority: int
    match: dict
    out_port: int | None  # None: drop; -1: to the controller
    cookie: int = 0


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


def base_flows(dpid: int, controller_vip: str) -> list[FlowAdd]:
    """What every OpenFlow switch gets on connect: table miss and the virtual controller IP to
    the controller (so unrequested traffic is seen, counted and dropped, never forwarded), IPv6
    noise dropped."""
    return [
        FlowAdd(dpid, PRIORITY_TABLE_MISS, {}, TO_CONTROLLER),
        FlowAdd(dpid, PRIORITY_DROP_NOISE, {"eth_type": ETH_TYPE_IPV6}, None),
        FlowAdd(dpid, PRIORITY_TO_CONTROLLER, {"eth_type": ETH_TYPE_IPV4, "ipv4_dst": controller_vip}, TO_CONTROLLER),
    ]


def udp_match(src_ip: str, dst_ip: str) -> dict:
    return {"eth_type": ETH_TYPE_IPV4, "ip_proto": IP_PROTO_UDP, "ipv4_src": src_ip, "ipv4_dst": dst_ip}


def path_flows(hops: list[tuple[str, int, int]], dpids: dict[str, int], a_ip: str, b_ip: str,
               cookie: int) -> list[FlowAdd]:
    """Both directions of a path given as (switch, port toward a, port toward b) hops."""
    flows = []
    for switch, toward_a, toward_b in hops:
        dpid = dpids[switch]
        flows.append(FlowAdd(dpid, PRIORITY_PATH, udp_match(a_ip, b_ip), toward_b, cookie))
        flows.append(FlowAdd(dpid, PRIORITY_PATH, udp_match(b_ip, a_ip), toward_a, cookie))
    return flows


def turbine_cookie(wid: int) -> int:
    return COOKIE_BASE + wid
