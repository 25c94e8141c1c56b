"""The fields the SDN app reads from a packet-in: Ethernet source, IPv4 source and destination, UDP
destination port and payload.

:func:`parse` reads the usual frame (untagged Ethernet II, IPv4 without options, UDP to a port
os-ken has no parser for) with one ``struct`` call; any other frame goes through os-ken's parser,
as before. Both give the same fields for the same bytes (``tests/unit/test_sdn_udp_frame.py``
compares them on mutated frames): os-ken takes the IPv4 payload up to ``total_length`` and the UDP
payload up to the UDP length, and drops a payload of zero bytes only. Parsing a frame with os-ken
costs ~16 µs warm and ~65 µs on the cold caches of an event loop woken by each packet-in.
"""

from __future__ import annotations

import socket
import struct
from typing import NamedTuple

from os_ken.lib.packet import ethernet, ipv4, packet, udp

ETH_HEADER = 14
IPV4_HEADER = 20  # without options (IHL = 5)
UDP_HEADER = 8
ETH_TYPE_IPV4 = 0x0800
IP_PROTO_UDP = 17
_HEADERS = struct.Struct("!6x6sH B x H 5x B 2x 4s4s HHH")  # eth src/type, ver+IHL, total length, proto, addrs, UDP ports/length


class UdpFrame(NamedTuple):
    eth_src: str  # "02:00:00:00:01:01", as os-ken writes it
    ip_src: str
    ip_dst: str
    dst_port: int
    payload: bytes  # b"" when the frame carries none (or only zero bytes)


class Unparsable(ValueError):
    """os-ken's parser raised on the frame."""


def parse(data: bytes) -> UdpFrame | None:
    """The frame's fields; None if it is not UDP in IPv4 in Ethernet; :class:`Unparsable` if
    os-ken's parser raises on it."""
    frame = _simple(data)
    return frame if frame is not None else _with_os_ken(data)


def _simple(data: bytes) -> UdpFrame | None:
    """The fields of the usual frame; None for any other (to be parsed by os-ken)."""
    if len(data) < ETH_HEADER + IPV4_HEADER + UDP_HEADER:
        return None
    mac, eth_type, ver_ihl, ip_len, proto, src, dst, sport, dport, udp_len = _HEADERS.unpack_from(data)
    if (eth_type != ETH_TYPE_IPV4 or ver_ihl != 0x45 or proto != IP_PROTO_UDP
            or not IPV4_HEADER + UDP_HEADER <= ip_len <= len(data) - ETH_HEADER
            or udp.udp.get_packet_type(sport, dport) is not None):
        return None
    ip_payload = data[ETH_HEADER + IPV4_HEADER:ETH_HEADER + ip_len]
    if not ip_payload.strip(b"\0"):
        return None  # os-ken stops before the UDP header: left to it
    payload = bytes(ip_payload[UDP_HEADER:udp_len])
    return UdpFrame(mac.hex(":"), socket.inet_ntoa(src), socket.inet_ntoa(dst), dport,
                    payload if payload.strip(b"\0") else b"")


def _with_os_ken(data: bytes) -> UdpFrame | None:
    try:
        pkt = packet.Packet(data)
    except Exception as exc:  # noqa: BLE001 - os-ken's parser raises many types on garbage
        raise Unparsable(str(exc)) from exc
    ip = pkt.get_protocol(ipv4.ipv4)
    u = pkt.get_protocol(udp.udp)
    eth = pkt.get_protocol(ethernet.ethernet)
    if ip is None or u is None or eth is None:
        return None
    payload = bytes(pkt.protocols[-1]) if isinstance(pkt.protocols[-1], (bytes, bytearray)) else b""
    return UdpFrame(eth.src, ip.src, ip.dst, u.dst_port, payload)
