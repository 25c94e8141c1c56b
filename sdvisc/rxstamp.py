"""Receive times taken by the kernel (``SO_TIMESTAMPNS``): when a datagram reached the socket, not
when a loop got round to reading it. On one machine ``time.time_ns`` (CLOCK_REALTIME) is one clock
for every network namespace, so a one-way delay is a plain difference of a sender's stamp and this.
"""

from __future__ import annotations

import socket
import struct
import time

_SO_TIMESTAMPNS = getattr(socket, "SO_TIMESTAMPNS", 35)
_TIMESPEC = struct.Struct("qq")


def enable(sock: socket.socket) -> None:
    """Ask the kernel to stamp every datagram ``sock`` receives."""
    sock.setsockopt(socket.SOL_SOCKET, _SO_TIMESTAMPNS, 1)


def recv(sock: socket.socket, bufsize: int = 2048) -> tuple[bytes, tuple, int] | None:
    """One datagram, its source and the kernel's receive time (ns; now if the kernel gave none), or
    None when nothing is waiting (non-blocking socket)."""
    try:
        data, ancdata, _flags, addr = sock.recvmsg(bufsize, socket.CMSG_SPACE(_TIMESPEC.size))
    except BlockingIOError:
        return None
    t_rx = 0
    for level, kind, raw in ancdata:
        if level == socket.SOL_SOCKET and kind == _SO_TIMESTAMPNS and len(raw) >= _TIMESPEC.size:
            sec, nsec = _TIMESPEC.unpack_from(raw)
            t_rx = sec * 1_000_000_000 + nsec
    return data, addr, t_rx or time.time_ns()
