"""Read packet captures of the testbed: a scapy GTNET-SKT layer and a pcap reader / command line tool.

Importing this module binds the :class:`GTNET` layer (VILLAS 3-word header) to the
testbed's UDP ports, so ``rdpcap(...)[0].show()`` names every word.  Captures of
plain GTNET-SKT without the header: call ``bind_gtnet(header=False)`` first.

``python -m host_tools.pcap FILE [--no-header] [--type MEAS] [--limit N]`` prints one
line per datagram and a count per message type and rejection reason.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

from scapy.error import Scapy_Exception
from scapy.fields import Field as ScapyField
from scapy.fields import IEEEFloatField, IntField, SignedIntEnumField, SignedIntField
from scapy.layers.inet import IP, UDP
from scapy.layers.inet6 import IPv6
from scapy.packet import Packet, bind_layers, split_layers
from scapy.utils import PcapReader

from sdvisc import wire
from sdvisc.wire import LAYOUTS, Message, MsgType, WireError

TESTBED_PORTS: tuple[int, ...] = tuple(wire.PORT_ROLES)

_MSG_TYPE_NAMES = {int(t): t.name for t in MsgType}


def _scapy_field(field: wire.Field) -> ScapyField:
    """The scapy field for one word of a layout."""
    if field.kind == "f32":
        return IEEEFloatField(field.name, 0.0)
    if field.enum is not None:
        return SignedIntEnumField(field.name, 0, {int(m): m.name for m in field.enum})
    return SignedIntField(field.name, 0)


class _GTNETBody(Packet):
    """Base of the per-type message bodies (the words after ``msg_type``)."""

    message_type: MsgType

    def mysummary(self) -> tuple[str, list[type[Packet]]]:
        pairs = (
            f"{f.name}={format_value(f, self.getfieldval(f.name))}" for f in LAYOUTS[self.message_type][1:]
        )
        return f"{self.name} {' '.join(pairs)}", [GTNET, GTNETNoHeader, UDP]


def _body_class(mtype: MsgType) -> type[Packet]:
    """A scapy layer whose fields are the words of ``mtype`` after ``msg_type``."""
    return type(
        f"GTNET_{mtype.name}",
        (_GTNETBody,),
        {"name": mtype.name, "message_type": mtype, "fields_desc": [_scapy_field(f) for f in LAYOUTS[mtype][1:]]},
    )


BODY_LAYERS: dict[int, type[Packet]] = {int(t): _body_class(t) for t in MsgType}
"""Scapy layer of each message type's body, keyed by the ``msg_type`` value."""


class GTNET(Packet):
    """GTNET-SKT datagram with the VILLAS fake header; the body follows as a per-type layer."""

    name = "GTNET-SKT"
    wire_header = True
    fields_desc = [
        IntField("hdr_seq", 0),
        IntField("hdr_sec", 0),
        IntField("hdr_nsec", 0),
        SignedIntEnumField("msg_type", 0, _MSG_TYPE_NAMES),
    ]

    def guess_payload_class(self, payload: bytes) -> type[Packet]:
        return BODY_LAYERS.get(self.msg_type, super().guess_payload_class(payload))

    def wire_bytes(self) -> bytes:
        """The datagram as captured (or as built, for packets made in code)."""
        return self.original if self.original else bytes(self)

    def to_message(self) -> Message:
        """Strictly decoded message; raises :class:`~sdvisc.wire.WireError` if malformed."""
        return wire.decode(self.wire_bytes(), header=self.wire_header)

    def wire_error(self) -> str | None:
        """Rejection reason of this datagram, or None if it is a valid testbed message."""
        try:
            self.to_message()
        except WireError as error:
            return error.reason
        return None

    def mysummary(self) -> str:
        error = self.wire_error()
        verdict = f" REJECTED({error})" if error else ""
        if self.wire_header:
            return f"GTNET-SKT #{self.hdr_seq}{verdict}"
        return f"GTNET-SKT{verdict}"


class GTNETNoHeader(GTNET):
    """GTNET-SKT datagram without the VILLAS header: ``msg_type`` is word 0."""

    name = "GTNET-SKT (no header)"
    wire_header = False
    fields_desc = [SignedIntEnumField("msg_type", 0, _MSG_TYPE_NAMES)]


def bind_gtnet(*, header: bool = True) -> None:
    """Dissect UDP payloads on the testbed ports as :class:`GTNET` (header) or :class:`GTNETNoHeader`."""
    active, inactive = (GTNET, GTNETNoHeader) if header else (GTNETNoHeader, GTNET)
    for port in TESTBED_PORTS:
        for direction in ("sport", "dport"):
            split_layers(UDP, inactive, **{direction: port})
            bind_layers(UDP, active, **{direction: port})


bind_gtnet(header=True)


@dataclass
class PcapRecord:
    """One testbed datagram of a capture; ``message`` is None and ``error`` the reason if rejected."""

    time: float
    src: str
    dst: str
    message: Message | None
    error: str | None


def _endpoint(address: str, port: int) -> str:
    return f"[{address}]:{port}" if ":" in address else f"{address}:{port}"


def _udp_payload(udp: UDP) -> bytes:
    """UDP payload exactly as captured, even when scapy dissected it into layers."""
    layer = udp.payload
    original = getattr(layer, "original", None)
    return bytes(original) if original is not None else bytes(layer)


def _testbed_udp(packet: Packet) -> UDP | None:
    """The packet's UDP layer if it is an IP/UDP datagram to or from a testbed port."""
    udp = packet.getlayer(UDP)
    if udp is None or type(udp) is not UDP or not isinstance(udp.underlayer, (IP, IPv6)):
        return None
    if udp.sport not in TESTBED_PORTS and udp.dport not in TESTBED_PORTS:
        return None
    return udp


def read_pcap(path: str, *, header: bool = True) -> Iterator[PcapRecord]:
    """Yield a record per testbed UDP datagram of a pcap/pcapng file; other packets are skipped."""
    with PcapReader(str(path)) as reader:
        for packet in reader:
            udp = _testbed_udp(packet)
            if udp is None:
                continue
            ip = udp.underlayer
            message, error = None, None
            try:
                message = wire.decode(_udp_payload(udp), header=header)
            except WireError as rejection:
                error = rejection.reason
            yield PcapRecord(
                time=float(packet.time),
                src=_endpoint(ip.src, udp.sport),
                dst=_endpoint(ip.dst, udp.dport),
                message=message,
                error=error,
            )


def format_value(field: wire.Field, value: int | float) -> str:
    """A value as printed: floats with 6 significant digits, enum codes by name, IPv4 words dotted."""
    if field.kind == "f32":
        return f"{value:.6g}"
    if field.enum is not None:
        try:
            return field.enum(value).name
        except ValueError:
            return str(value)
    if field.unit == "IPv4":
        return wire.i32_to_ip(int(value))
    return str(value)


def format_message(message: Message) -> str:
    """``TYPE [#hdr_seq] name=value ...`` on one line."""
    parts = [message.type.name]
    if message.header is not None:
        parts.append(f"#{message.header.seq}")
    parts += [f"{f.name}={format_value(f, message[f.name])}" for f in LAYOUTS[message.type][1:]]
    return " ".join(parts)


def format_record(record: PcapRecord) -> str:
    """One CLI output line for a record."""
    body = format_message(record.message) if record.message is not None else f"REJECTED {record.error}"
    return f"{record.time:.6f} {record.src} -> {record.dst} {body}"


def _message_type(name: str) -> MsgType:
    try:
        return MsgType[name.upper()]
    except KeyError:
        raise argparse.ArgumentTypeError(f"unknown type {name!r}; one of {[t.name for t in MsgType]}") from None


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m host_tools.pcap",
        description="Print the SDViSC GTNET-SKT datagrams of a pcap/pcapng capture, then counts.",
    )
    parser.add_argument("file", help="pcap or pcapng capture")
    parser.add_argument("--no-header", action="store_true", help="payloads have no VILLAS 3-word header")
    parser.add_argument("--type", type=_message_type, help="print only this message type (e.g. MEAS)")
    parser.add_argument("--limit", type=int, default=None, metavar="N", help="stop after printing N lines")
    return parser


def _print_counts(types: Counter[str], reasons: Counter[str]) -> None:
    total = sum(types.values()) + sum(reasons.values())
    print(f"--- {total} datagrams: {sum(types.values())} decoded, {sum(reasons.values())} rejected")
    for mtype in MsgType:
        if types[mtype.name]:
            print(f"{mtype.name:<10} {types[mtype.name]}")
    for reason in wire.REJECT_REASONS:
        if reasons[reason]:
            print(f"rejected {reason:<10} {reasons[reason]}")


def main(argv: Sequence[str] | None = None) -> int:
    """Command line entry point; returns the exit status."""
    args = _parser().parse_args(argv)
    types: Counter[str] = Counter()
    reasons: Counter[str] = Counter()
    printed = 0
    try:
        for record in read_pcap(args.file, header=not args.no_header):
            if args.limit is not None and printed >= args.limit:
                break
            if record.message is not None:
                types[record.message.type.name] += 1
            else:
                reasons[str(record.error)] += 1
            wanted = args.type is None or (record.message is not None and record.message.type == args.type)
            if wanted:
                print(format_record(record))
                printed += 1
    except (OSError, Scapy_Exception) as error:
        print(f"error: cannot read {args.file}: {error}", file=sys.stderr)
        return 2
    _print_counts(types, reasons)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
