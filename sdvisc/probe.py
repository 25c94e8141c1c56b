"""Network probes for the time-scale calibration: datagrams the size of a MEAS, stamped with the
send time, echoed by a separate process in the SDC's namespace, receive times taken by the kernel.

Both ends live on one machine, so ``time.time_ns`` (CLOCK_REALTIME) is one clock for every
namespace and a one-way delay is a plain difference. Receive times come from ``SO_TIMESTAMPNS``
(the kernel's stamp when the datagram reached the socket), so they do not depend on when the
receiving loop got round to reading it.

``python -m sdvisc.probe echo --bind IP --port P --out FILE`` runs the echo until SIGTERM, then
writes how many datagrams it echoed and how many it dropped as malformed.
"""

from __future__ import annotations

import argparse
import json
import select
import signal
import socket
import struct
import time
from pathlib import Path

from sdvisc.jsonlines import write_json_atomic
from sdvisc.wire import MsgType, packer

PROBE_PORT = 47990
MAGIC = 0x5D5CA1E0
_HEAD = struct.Struct(">IIIqq")  # magic, turbine id, seq, t_send_ns, t_echo_rx_ns (0 on the way out)
PAYLOAD_BYTES = max(_HEAD.size, packer(MsgType.MEAS, header=True).size)
"""A probe is as large as a MEAS with its GTNET header (the switches' per-byte work is the same)."""
_PAD = bytes(PAYLOAD_BYTES - _HEAD.size)
_SO_TIMESTAMPNS = getattr(socket, "SO_TIMESTAMPNS", 35)
_SCM_TIMESTAMPNS = _SO_TIMESTAMPNS
_TIMESPEC = struct.Struct("qq")


def encode(wid: int, seq: int, t_send_ns: int, t_echo_rx_ns: int = 0) -> bytes:
    return _HEAD.pack(MAGIC, wid, seq, t_send_ns, t_echo_rx_ns) + _PAD


def decode(data: bytes) -> tuple[int, int, int, int] | None:
    """``(wid, seq, t_send_ns, t_echo_rx_ns)`` of a probe, or None for anything else."""
    if len(data) != PAYLOAD_BYTES:
        return None
    magic, wid, seq, t_send, t_echo = _HEAD.unpack_from(data)
    if magic != MAGIC or t_send <= 0 or t_echo < 0:
        return None
    return wid, seq, t_send, t_echo


def enable_rx_timestamps(sock: socket.socket) -> None:
    sock.setsockopt(socket.SOL_SOCKET, _SO_TIMESTAMPNS, 1)


def recv_stamped(sock: socket.socket) -> tuple[bytes, tuple, int] | None:
    """One datagram, its source and the kernel's receive time (ns; now if the kernel gave none)."""
    try:
        data, ancdata, _flags, addr = sock.recvmsg(2048, socket.CMSG_SPACE(_TIMESPEC.size))
    except BlockingIOError:
        return None
    t_rx = 0
    for level, kind, raw in ancdata:
        if level == socket.SOL_SOCKET and kind == _SCM_TIMESTAMPNS and len(raw) >= _TIMESPEC.size:
            sec, nsec = _TIMESPEC.unpack_from(raw)
            t_rx = sec * 1_000_000_000 + nsec
    return data, addr, t_rx or time.time_ns()


def run_echo(bind_ip: str, port: int, out: Path) -> None:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
    sock.bind((bind_ip, port))
    sock.setblocking(False)
    enable_rx_timestamps(sock)
    counts = {"echoed": 0, "malformed": 0}
    stop = []
    signal.signal(signal.SIGTERM, lambda *_: stop.append(1))
    write_json_atomic(out, {"ready": True, **counts})
    while not stop:
        try:
            ready, _, _ = select.select([sock], [], [], 0.1)
        except InterruptedError:
            continue
        if not ready:
            continue
        while (got := recv_stamped(sock)) is not None:
            data, addr, t_rx = got
            probe = decode(data)
            if probe is None:
                counts["malformed"] += 1
                continue
            wid, seq, t_send, _ = probe
            sock.sendto(encode(wid, seq, t_send, t_rx), addr)
            counts["echoed"] += 1
    write_json_atomic(out, {"ready": True, "done": True, **counts})


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sdvisc.probe", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="cmd", required=True)
    echo = sub.add_parser("echo", help="echo probes back with their receive time until SIGTERM")
    echo.add_argument("--bind", required=True)
    echo.add_argument("--port", type=int, default=PROBE_PORT)
    echo.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    run_echo(args.bind, args.port, args.out)
    print(json.dumps({"done": True}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
