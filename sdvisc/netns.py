"""Open sockets inside other network namespaces (Mininet hosts) from one process.

Python 3.11 has no ``os.setns``; libc's ``setns(fd, CLONE_NEWNET)`` switches the calling thread.
A socket keeps the namespace it was created in after the thread switches back, so one process
can own endpoints in many hosts (PLATFORM.md).
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import socket

CLONE_NEWNET = 0x40000000
_libc = ctypes.CDLL(None, use_errno=True)


def _setns(fd: int) -> None:
    if _libc.setns(fd, CLONE_NEWNET) != 0:
        err = ctypes.get_errno()
        raise OSError(err, f"setns failed: {os.strerror(err)}")


@contextlib.contextmanager
def netns_of(pid: int):
    """Run the body inside the network namespace of process ``pid``, then switch back."""
    own = os.open("/proc/self/ns/net", os.O_RDONLY)
    target = os.open(f"/proc/{pid}/ns/net", os.O_RDONLY)
    try:
        _setns(target)
        try:
            yield
        finally:
            _setns(own)
    finally:
        os.close(target)
        os.close(own)


def udp_socket_in(pid: int | None, bind_ip: str, bind_port: int, *, rcvbuf: int = 1 << 20) -> socket.socket:
    """A non-blocking UDP socket bound to ``bind_ip:bind_port`` in the namespace of ``pid``
    (the current namespace if ``pid`` is None)."""
    ctx = netns_of(pid) if pid is not None else contextlib.nullcontext()
    with ctx:
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)
        sock.bind((bind_ip, bind_port))
    sock.setblocking(False)
    return sock


def raise_priority(priority: int = 10) -> str:
    """Ask for SCHED_FIFO ``priority`` for this process (root only); returns what was obtained.

    The paced loops sleep between steps, so a real-time class mostly shortens wake-up latency;
    the kernel's RT throttling keeps the rest of the machine alive.
    """
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
        return f"SCHED_FIFO:{priority}"
    except (AttributeError, PermissionError, OSError):
        try:
            os.nice(-10)
            return "nice:-10"
        except OSError:
            return "default"
