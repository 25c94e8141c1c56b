"""What an endpoint relay would cost per datagram (issue 30, item 2; docs/cluster.md "Why the
turbines stay with the plant").

The alternative to keeping the turbine hosts with the plant is an agent on each server that owns the
sockets of the turbines placed there and relays their MEAS, CTRL and AKs to and from the plant over
one connection per server. Whatever the connection, every datagram then costs one more user-space
receive and send (on the server) than it does now, plus the LAN crossing both designs have. This
measures that extra hop as the project would write it (Python, one blocking socket per side, the
plant's MEAS size): a sender paces ``--rate`` datagrams per second through a relay process to a
receiver, and directly to the same receiver, on this machine's loopback; it reports the relay
process's CPU per datagram and the one-way delay with and without it (each datagram carries its
send time on the system-wide monotonic clock).

    python benchmarks/relay_cost.py [--count 20000] [--rate 5000] [--size 104] [--json F]
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import resource
import socket
import struct
import sys
import time
from pathlib import Path

import numpy as np

STAMP = struct.Struct("!Q")


def relay(listen: int, to: int, count: int, ready, report) -> None:
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", listen))
    tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    ready.set()
    buf = bytearray(2048)
    got = 0
    start = resource.getrusage(resource.RUSAGE_SELF)
    while got < count:
        n = rx.recv_into(buf)
        tx.sendto(memoryview(buf)[:n], ("127.0.0.1", to))
        got += 1
    end = resource.getrusage(resource.RUSAGE_SELF)
    report.put((end.ru_utime - start.ru_utime) + (end.ru_stime - start.ru_stime))


def receive(port: int, count: int, ready, report) -> None:
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 22)
    rx.bind(("127.0.0.1", port))
    rx.settimeout(10)
    ready.set()
    delays = []
    try:
        for _ in range(count):
            data = rx.recv(2048)
            delays.append(time.monotonic_ns() - STAMP.unpack_from(data)[0])
    except TimeoutError:
        pass
    report.put(delays)


def send(port: int, count: int, rate: float, size: int) -> None:
    tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    pad = bytes(size - STAMP.size)
    period = 1e9 / rate
    t_next = time.monotonic_ns()
    for _ in range(count):
        while time.monotonic_ns() < t_next:
            pass
        tx.sendto(STAMP.pack(time.monotonic_ns()) + pad, ("127.0.0.1", port))
        t_next += period


def one_case(with_relay: bool, count: int, rate: float, size: int, base: int) -> dict:
    ctx = mp.get_context("fork")
    rx_ready, relay_ready = ctx.Event(), ctx.Event()
    delays_q, cpu_q = ctx.Queue(), ctx.Queue()
    receiver = ctx.Process(target=receive, args=(base, count, rx_ready, delays_q))
    receiver.start()
    rx_ready.wait(10)
    target = base
    relayer = None
    if with_relay:
        relayer = ctx.Process(target=relay, args=(base + 1, base, count, relay_ready, cpu_q))
        relayer.start()
        relay_ready.wait(10)
        target = base + 1
    send(target, count, rate, size)
    delays = np.array(delays_q.get(timeout=60)) / 1e3  # µs
    receiver.join(10)
    out = {"received": int(delays.size), "one_way_us": {"p50": round(float(np.median(delays)), 1),
                                                        "p99": round(float(np.percentile(delays, 99)), 1)}}
    if relayer is not None:
        try:
            cpu_s = cpu_q.get(timeout=5)
            out["relay_cpu_us_per_datagram"] = round(cpu_s * 1e6 / count, 2)
        except Exception:  # noqa: BLE001 - the relay lost datagrams and never finished counting
            out["relay_cpu_us_per_datagram"] = None
        relayer.terminate()
        relayer.join(5)
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=20000)
    ap.add_argument("--rate", type=float, default=5000.0, help="datagrams per second (a few ViSCs at Ts = 0.67 ms)")
    ap.add_argument("--size", type=int, default=104, help="bytes per datagram (a MEAS with its header)")
    ap.add_argument("--port", type=int, default=47610)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    direct = one_case(False, args.count, args.rate, args.size, args.port)
    relayed = one_case(True, args.count, args.rate, args.size, args.port + 10)
    result = {"count": args.count, "rate": args.rate, "size": args.size, "direct": direct, "relayed": relayed,
              "added_one_way_us_p50": round(relayed["one_way_us"]["p50"] - direct["one_way_us"]["p50"], 1),
              "machine": {"cpus": os.cpu_count(), "load": os.getloadavg()}}
    text = json.dumps(result, indent=1)
    if args.json:
        args.json.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
