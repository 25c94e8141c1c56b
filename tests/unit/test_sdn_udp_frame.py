"""sdn_app.udp_frame: the struct path reads the same fields as os-ken's parser, on any bytes."""

import random

import pytest
from os_ken.lib.packet import ethernet, ipv4, packet, udp

from sdn_app import udp_frame
from sdvisc import wire


def frame(payload: bytes, *, src_port: int = wire.PORT_TURBINE, dst_port: int = wire.PORT_CONTROLLER,
          ethertype: int = 0x0800, proto: int = 17) -> bytes:
    p = packet.Packet()
    p.add_protocol(ethernet.ethernet(dst="02:00:00:00:00:fe", src="02:00:00:00:01:0a", ethertype=ethertype))
    p.add_protocol(ipv4.ipv4(src="10.0.1.10", dst="10.0.0.254", proto=proto))
    p.add_protocol(udp.udp(src_port=src_port, dst_port=dst_port))
    p.add_protocol(payload)
    p.serialize()
    return bytes(p.data)


AK = wire.encode(wire.MsgType.AK, {"wt": 110, "seq": 7, "ak": 1, "ctrl_rx": 99, "ctrl_age_ms": 0.25},
                 header=wire.Header(7, 1, 2))


def os_ken_fields(data: bytes):
    try:
        return udp_frame._with_os_ken(data)
    except udp_frame.Unparsable:
        return "unparsable"


def test_an_ak_frame_is_read_without_os_ken():
    fields = udp_frame._simple(frame(AK))
    assert fields == udp_frame.UdpFrame("02:00:00:00:01:0a", "10.0.1.10", "10.0.0.254", wire.PORT_CONTROLLER, AK)
    assert fields == os_ken_fields(frame(AK))


@pytest.mark.parametrize("data", [
    frame(AK, ethertype=0x86DD), frame(AK, proto=6), frame(AK, dst_port=4789), frame(AK, src_port=67, dst_port=67),
    frame(AK)[:40], b"", b"\0" * 64,
])
def test_other_frames_are_left_to_os_ken(data):
    assert udp_frame._simple(data) is None


def test_short_or_zero_payloads_read_as_os_ken_reads_them():
    for payload in (b"", b"\0" * 4, b"\0\0\0\x01", AK[:5]):
        data = frame(payload)
        assert udp_frame.parse(data) == os_ken_fields(data), payload


def test_mutated_frames_read_the_same_either_way():
    rng = random.Random(8)
    base = frame(AK)
    simple = 0
    for _ in range(3000):
        data = bytearray(base)
        for _ in range(rng.randint(1, 4)):
            data[rng.randrange(len(data))] = rng.choice((0, 0x45, 0xFF, rng.randrange(256)))
        if rng.random() < 0.2:
            data = data[:rng.randrange(len(data) + 1)]
        data = bytes(data)
        fast = udp_frame._simple(data)
        if fast is not None:
            simple += 1
            assert fast == os_ken_fields(data), data.hex()
    assert simple > 1000  # most mutations keep the usual form
