"""host_tools.fuzz's sender from a turbine's own UDP port (a raw socket writing the UDP header: the
plant holds the port, and the switches carry a turbine's datagrams to its SDC only from it). Needs
root for the raw socket, hence the network marker; loopback only."""

from __future__ import annotations

import socket

import pytest

from host_tools.fuzz import udp_sender

pytestmark = pytest.mark.network


def test_datagrams_leave_from_the_given_port_even_while_another_socket_holds_it():
    holder = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    holder.bind(("127.0.0.1", 0))
    port = holder.getsockname()[1]  # as the plant holds a turbine's port
    sink = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sink.bind(("127.0.0.1", 0))
    sink.settimeout(2.0)
    sock, sendto = udp_sender(port)
    try:
        for payload in (b"", b"x" * 13, bytes(range(256)) * 5):
            sendto(payload, sink.getsockname())
            data, (_, src_port) = sink.recvfrom(4096)
            assert (data, src_port) == (payload, port)
    finally:
        for s in (sock, sink, holder):
            s.close()


def test_without_a_port_an_ordinary_socket_sends():
    sink = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sink.bind(("127.0.0.1", 0))
    sink.settimeout(2.0)
    sock, sendto = udp_sender(None)
    try:
        sendto(b"abc", sink.getsockname())
        assert sink.recvfrom(64)[0] == b"abc"
    finally:
        sock.close()
        sink.close()
