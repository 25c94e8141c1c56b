"""How long a process sleeping in ``recv`` takes to run after a datagram reaches it when its CPU is
shared with a busy process — at SCHED_OTHER (ovs-vswitchd's default) and at SCHED_FIFO (the plant
and the SDC services' ``realtime_priority``). No network, no Open vSwitch: the mechanism alone.

A receiver pinned to the switch's CPU (the highest, as ``cpu_split`` pins ovs-vswitchd) blocks in
``recv`` on a loopback UDP socket; a sender pinned to CPU 0 (at :data:`SENDER_PRIORITY`) sends its ``perf_counter_ns`` every
``--gap-ms``; the wake latency is the receiver's clock after ``recv`` minus the stamp. With
``--hog`` a busy loop (``while 1: pass``, ordinary priority) runs on the receiver's CPU, as another
process of the machine would. Issue 42 item 6: all_visc_50's answers at k = 8 came up to ~4.4 ms
of wall time late on the return path (SDC → switch → turbine), the same for every turbine and every
k — one scheduler tick (this kernel: CONFIG_HZ=250, 4 ms), while plant and SDC run at SCHED_FIFO
and the switch does not.

Prints one JSON object (p50/p99/max µs per policy, the load before and after). Linux, root (FIFO),
two CPUs or more:

    python benchmarks/switch_wake_latency.py [--count 1500] [--gap-ms 5] [--no-hog] [--out FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

SENDER_PRIORITY = 20
"""SCHED_FIFO priority of the sender: above the services' (10), so that another run's plant or SDC on
CPU 0 does not delay it between its stamp and its send (that would be counted as the receiver's)."""


def measure(policy: str, cpu: int, count: int, gap_s: float, hog: bool) -> dict:
    """One receiver at ``policy`` (``other``/``fifo``) on ``cpu``: wake latencies of ``count`` datagrams."""
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:  # the receiver
        os.close(read_end)
        os.sched_setaffinity(0, {cpu})
        if policy == "fifo":
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(5))
        lat = []
        while (data := rx.recv(64)) != b"end":
            lat.append((time.perf_counter_ns() - int(data)) / 1e3)
        os.write(write_end, json.dumps(lat).encode())
        os._exit(0)
    os.close(write_end)
    busy = subprocess.Popen(["taskset", "-c", str(cpu), sys.executable, "-c", "while 1: pass"]) if hog else None
    try:
        os.sched_setaffinity(0, {0})
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(SENDER_PRIORITY))  # stamp and send at once
        tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        time.sleep(0.2)
        for _ in range(count):
            tx.sendto(str(time.perf_counter_ns()).encode(), rx.getsockname())
            time.sleep(gap_s)
        tx.sendto(b"end", rx.getsockname())
        chunks = []
        while chunk := os.read(read_end, 1 << 20):
            chunks.append(chunk)
        os.waitpid(pid, 0)
    finally:
        os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
        if busy is not None:
            busy.kill()
            busy.wait()
        os.close(read_end)
    lat = np.array(json.loads(b"".join(chunks)))
    return {"policy": policy, "hog": hog, "n": int(lat.size), "p50_us": round(float(np.percentile(lat, 50)), 1),
            "p99_us": round(float(np.percentile(lat, 99)), 1), "max_us": round(float(lat.max()), 1)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--count", type=int, default=1500)
    ap.add_argument("--gap-ms", type=float, default=5.0)
    ap.add_argument("--no-hog", action="store_true", help="no busy process on the receiver's CPU")
    ap.add_argument("--out", type=Path)
    args = ap.parse_args(argv)
    cpu = max(os.sched_getaffinity(0))
    if cpu == 0:
        raise SystemExit("needs two CPUs")
    result = {"benchmark": "switch wake latency", "receiver_cpu": cpu, "load_before": os.getloadavg(),
              "cases": [measure(p, cpu, args.count, args.gap_ms * 1e-3, not args.no_hog) for p in ("other", "fifo")],
              "load_after": os.getloadavg()}
    text = json.dumps(result, indent=1)
    print(text)
    if args.out:
        args.out.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
