"""CPU per SDC service round: the real ``sdc_unit.service`` code, offline, in µs of process CPU.

Prints ONE JSON object. Each case builds an :class:`sdc_unit.service.SdcService`, starts N
instances with REQUEST datagrams as the SDN app would, then feeds it realistic MEAS datagrams
(``sdc_throughput.realistic_measurements``, one per turbine and sample, seq and t_sim advancing)
through the service's own ``serve`` (:meth:`sdc_unit.core.SdcCore.handle`: admission, stepping,
CTRL encoding; then the ``sendto`` calls), either

* ``socket: "memory"`` (default): the datagrams handed to ``serve`` directly, the CTRL datagrams
  taken by an in-memory socket -- the service's Python and numpy work only; or
* ``socket: "udp"`` (``--udp``): over loopback UDP (no Mininet): a sender socket on 127.0.8.1 sends
  each round's MEAS to the service socket, the service reads them with its ``wake`` (the
  ``recvfrom`` loop) and sends the CTRL back to the sender on 127.0.8.1:``wire.PORT_TURBINE`` (where the MEAS came from).

Rounds: ``single`` = each datagram is its own round (what the service does when the turbines' MEAS
arrive apart, the usual case with few turbines); ``batch`` = the N MEAS of one sample in one round.
The fit over N of the ``batch`` rounds gives the fixed cost per round and the cost per instance.

CPU is the process's (``time.process_time``); the median of ``--repeat`` repetitions is reported.
``--gap-ms G`` sleeps G ms before each in-memory round and counts only the rounds' own CPU: what a
round costs when, as in a run, the service sleeps between MEAS and other processes use the caches.

    .venv/bin/python benchmarks/sdc_round_cost.py                    # ~15 s
    .venv/bin/python benchmarks/sdc_round_cost.py --udp
    .venv/bin/python benchmarks/sdc_round_cost.py --ns 4 --modes single --gap-ms 1.3
"""

from __future__ import annotations

import argparse
import json
import os
import select
import socket
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # as the runner's services (an idle pool would count as CPU)

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))  # sdc_throughput, also when imported by a test

from sdc_throughput import N_SAMPLES, TS, machine, realistic_measurements  # noqa: E402 - benchmarks/

from sdc_unit.service import SdcService  # noqa: E402
from sdvisc import wire  # noqa: E402
from sdvisc.config import SdcConfig  # noqa: E402
from sdvisc.vocabulary import BLANK_REQUEST_PARAMS, MEAS_FIELDS  # noqa: E402

FARM_TURBINES = 50
"""The runner sizes an SDC for every turbine host of the topology (5 x 10 on the farm network)."""
SENDER_IP = "127.0.8.1"
"""Loopback address of the benchmark's turbines (apart from the unit tests' 127.0.0.1)."""


class MemorySocket:
    """What the service needs of a socket when the datagrams are handed to ``serve`` directly."""

    def __init__(self) -> None:
        self.sent = 0
        self.sent_bytes = 0

    def sendto(self, data: bytes, addr) -> int:
        self.sent += 1
        self.sent_bytes += len(data)
        return len(data)


def _request(wid: int, req_id: int) -> bytes:
    values = {"req_id": req_id, "cmd": int(wire.Command.START_INSTANCE), "wt": wid, "sdc_ip": 0,
              **BLANK_REQUEST_PARAMS}
    return wire.encode(wire.MsgType.REQUEST, values, header=wire.Header(req_id, 0, 0))


def turbine_ids(n: int) -> list[int]:
    return [wire.turbine_id(j // 10 + 1, j % 10 + 1) for j in range(n)]


def meas_stream(n: int, samples: int) -> list[list[bytes]]:
    """``samples`` consecutive MEAS samples of ``n`` turbines (the ripple of ``realistic_measurements``
    cycled), seq and t_sim advancing as the plant sends them."""
    ops = realistic_measurements(n)
    wids = turbine_ids(n)
    out = []
    for k in range(samples):
        m = ops[k % N_SAMPLES]
        t_sim = k * TS
        header = wire.Header(k, int(t_sim), int((t_sim % 1.0) * 1e9))
        out.append([wire.encode(wire.MsgType.MEAS, {"wt": wid, "seq": k, "t_sim": t_sim,
                                                   **{key: float(m[key][j]) for key in MEAS_FIELDS}}, header=header)
                    for j, wid in enumerate(wids)])
    return out


def make_service(n: int, sock, controller_ip: str) -> SdcService:
    cfg = SdcConfig(step_s=TS, controller_vip=controller_ip, bind_ip="127.0.0.1", capacity=max(n, FARM_TURBINES),
                    out_dir=tempfile.gettempdir(), realtime_priority=False)
    svc = SdcService(cfg, sock=sock)
    svc.bank.warm_up()
    for j, wid in enumerate(turbine_ids(n)):
        svc.serve([(_request(wid, j + 1), (controller_ip, wire.PORT_CONTROLLER))], 0.0)
    return svc


def rounds_of(stream: list[list[bytes]], mode: str) -> list[list[bytes]]:
    if mode == "batch":
        return stream
    return [[d] for sample in stream for d in sample]


def run_memory(n: int, mode: str, rounds: int, warm: int, gap_s: float = 0.0) -> dict:
    """``rounds`` service rounds after ``warm`` unmeasured ones; µs per round (perf_counter).
    ``gap_s`` > 0: sleep that long before each round (as the service waits for the next MEAS) and
    count only the rounds' own CPU (``time.thread_time``): a round on cold caches."""
    sock = MemorySocket()
    svc = make_service(n, sock, "10.0.0.254")
    per_sample = 1 if mode == "batch" else n
    stream = rounds_of(meas_stream(n, -(-(rounds + warm) // per_sample)), mode)[:rounds + warm]
    addrs = [(f"10.0.{j // 10 + 1}.{j % 10 + 1}", wire.PORT_TURBINE) for j in range(n)]
    sender = {wid: a for wid, a in zip(turbine_ids(n), addrs)}
    feeds = []
    for k, datagrams in enumerate(stream):
        now = (k // (n if mode == "single" else 1)) * TS
        feeds.append(([(d, sender[int.from_bytes(d[16:20], "big")]) for d in datagrams], now))
    serve = svc.serve
    for datagrams, now in feeds[:warm]:
        serve(datagrams, now)
    if gap_s > 0:
        wall = cpu = 0.0
        for datagrams, now in feeds[warm:]:
            time.sleep(gap_s)
            cpu0, t0 = time.thread_time(), time.perf_counter()
            serve(datagrams, now)
            wall, cpu = wall + time.perf_counter() - t0, cpu + time.thread_time() - cpu0
    else:
        cpu0, t0 = time.process_time(), time.perf_counter()
        for datagrams, now in feeds[warm:]:
            serve(datagrams, now)
        wall, cpu = time.perf_counter() - t0, time.process_time() - cpu0
    expected = (rounds + warm) * (n if mode == "batch" else 1) + n  # + the REPLY to each START_INSTANCE
    return {"n": n, "rounds": mode, "us_per_round": round(wall / rounds * 1e6, 2),
            "cpu_us_per_round": round(cpu / rounds * 1e6, 2), "ctrl_sent": sock.sent, "ctrl_expected": expected,
            "rejected": dict(svc.rejected)}


def run_udp(n: int, mode: str, rounds: int, warm: int) -> dict:
    """As :func:`run_memory` over loopback UDP: the service's ``wake`` and real ``sendto``."""
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 21)
    rx.bind(("127.0.0.1", 0))
    rx.setblocking(False)
    tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)  # the turbines' port: the SDC answers where a MEAS came from
    tx.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 23)
    tx.bind((SENDER_IP, wire.PORT_TURBINE))
    tx.setblocking(False)
    sink = tx
    try:
        svc = make_service(n, rx, SENDER_IP)
        dst = rx.getsockname()
        per_sample = 1 if mode == "batch" else n
        stream = rounds_of(meas_stream(n, -(-(rounds + warm) // per_sample)), mode)[:rounds + warm]
        poller = select.epoll()
        poller.register(rx.fileno(), select.EPOLLIN)
        received = 0
        cpu0 = t0 = 0.0
        for k, datagrams in enumerate(stream):
            if k == warm:
                cpu0, t0 = time.process_time(), time.perf_counter()
            for d in datagrams:
                tx.sendto(d, dst)
            poller.poll(0.1)  # as the service's loop: wake up, read everything waiting, serve it
            now = k * TS
            svc.wake(now)
            while True:  # keep the sink empty (its cost is counted, as a turbine's would be elsewhere)
                try:
                    sink.recv(2048)
                    received += 1
                except BlockingIOError:
                    break
        wall, cpu = time.perf_counter() - t0, time.process_time() - cpu0
        poller.close()
        return {"n": n, "rounds": mode, "us_per_round": round(wall / rounds * 1e6, 2),
                "cpu_us_per_round": round(cpu / rounds * 1e6, 2), "ctrl_received": received,
                "rejected": dict(svc.rejected), "note": "includes the sender's sendto and the sink's recv"}
    finally:
        for s in (rx, tx):
            s.close()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ns", default="1,4,16,50", help="turbines served (comma-separated)")
    ap.add_argument("--modes", default="single,batch", help="single, batch or both")
    ap.add_argument("--rounds", type=int, default=3000, help="measured rounds per case")
    ap.add_argument("--warm", type=int, default=200, help="unmeasured rounds first")
    ap.add_argument("--repeat", type=int, default=3, help="timed repetitions per case (median reported)")
    ap.add_argument("--udp", action="store_true", help="over loopback UDP sockets instead of an in-memory socket")
    ap.add_argument("--gap-ms", type=float, default=0.0,
                    help="in-memory rounds: sleep this long before each one and count only the rounds' CPU "
                         "(cold caches, as a service woken by each MEAS)")
    args = ap.parse_args(argv)
    ns = [int(x) for x in args.ns.split(",")]
    modes = args.modes.split(",")
    load0 = os.getloadavg()
    cases = []
    for n in ns:
        for mode in modes:
            if mode == "single" and n > 4 and "batch" in modes:
                continue  # one turbine per round costs the same whatever N: measured at N <= 4
            reps = [run_udp(n, mode, args.rounds, args.warm) if args.udp
                    else run_memory(n, mode, args.rounds, args.warm, args.gap_ms * 1e-3) for _ in range(args.repeat)]
            best = sorted(reps, key=lambda r: r["cpu_us_per_round"])[len(reps) // 2]
            best["cpu_us_per_round_all"] = [r["cpu_us_per_round"] for r in reps]
            cases.append(best)
    result = {"benchmark": "sdc_round_cost", "socket": "udp" if args.udp else "memory", "gap_ms": args.gap_ms,
              "cases": cases}
    batch = [(c["n"], c["cpu_us_per_round"]) for c in cases if c["rounds"] == "batch"]
    if len(batch) >= 2:
        slope, icpt = np.polyfit([b[0] for b in batch], [b[1] for b in batch], 1)
        result["batch_fit"] = {"per_round": round(float(icpt), 1), "per_instance": round(float(slope), 2)}
    result["machine"] = {**machine(), "loadavg_1min_before": round(load0[0], 2),
                         "loadavg_1min_after": round(os.getloadavg()[0], 2)}
    print(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
