"""Open sockets inside other network namespaces (Mininet hosts) from one process.

Python 3.11 has no ``os.setns``; libc's ``setns(fd, CLONE_NEWNET)`` switches the calling thread.
A socket keeps the namespace it was created in after the thread switches back, so one process
can own endpoints in many hosts (PLATFORM.md).
"""

from __future__ import annotations

import contextlib
import ctypes
import fcntl
import os
import socket
import struct
import time

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


SIOCGIFFLAGS = 0x8913
SIOCSIFFLAGS = 0x8914
IFF_UP = 0x1


def set_link_up(ifname: str, up: bool, pid: int | None = None) -> float:
    """Set interface ``ifname`` (in the namespace of ``pid``, or this one) up or down with one
    ioctl, as ``ip link set`` does but without starting a process (~2 ms), so a link failure
    happens at a known instant; returns the wall time just before the change."""
    ctx = netns_of(pid) if pid is not None else contextlib.nullcontext()
    with ctx, socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        name = ifname.encode()
        if len(name) > 15:
            raise ValueError(f"interface name too long: {ifname!r}")
        flags = struct.unpack("16sH", fcntl.ioctl(sock, SIOCGIFFLAGS, struct.pack("16sH", name, 0)))[1]
        flags = flags | IFF_UP if up else flags & ~IFF_UP
        t = time.time()
        fcntl.ioctl(sock, SIOCSIFFLAGS, struct.pack("16sH", name, flags))
    return t


CLOCK_TICKS = os.sysconf("SC_CLK_TCK")
"""/proc's clock ticks per second (USER_HZ: 100 on every Linux Mininet runs on, so a server's too)."""


def stat_cpu_seconds(stat: str) -> float:
    """User + system CPU seconds in the text of a ``/proc/PID/stat`` (fields 14 and 15: utime, stime);
    ValueError if it is not one."""
    try:
        fields = stat.rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / CLOCK_TICKS
    except (IndexError, ValueError):
        raise ValueError("not the text of a /proc/PID/stat") from None


def cpu_seconds_of(pid: int | str) -> float | None:
    """User + system CPU seconds of process (or thread) ``pid`` (/proc), or None if it is gone."""
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return stat_cpu_seconds(fh.read())
    except (OSError, ValueError):
        return None


def command_line(pid: int | str) -> str | None:
    """The command line of process ``pid`` (arguments joined by spaces; empty for a kernel thread),
    or None if it is gone."""
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as fh:
            return fh.read().replace(b"\0", b" ").decode(errors="replace").strip()
    except OSError:
        return None
