"""An impairment element: forwards Ethernet frames between two interfaces through a timed queue.

``python -m impairment.element --config FILE`` runs inside a Mininet host that sits in a
switch-to-switch link (one interface toward each switch; topologies.base). Where the kernel has no
``netem`` this is how the testbed delays, jitters and drops frames on a link. It is transparent at
L2: raw ``AF_PACKET`` sockets on both interfaces (promiscuous, offloads off, its own outgoing frames
ignored), no IP or IPv6 of its own, so the switches see each other as neighbours, port status and
link failures pass through (the runner takes the element's interfaces down with the link).

Each direction is a :class:`impairment.queue.TimedQueue` on the run's clock (simulated seconds,
so delays scale with ``time_scale``); a frame's arrival time is the kernel's receive timestamp.
Bandwidth, if set, is a TBF qdisc on each egress interface at ``bw_mbps / time_scale`` of wall
rate (so it is ``bw_mbps`` in simulated time). Commands arrive as JSON lines on stdin::

    {"cmd": "set", "impairment": {"delay_ms": 5, "jitter_ms": 0, "loss": 0.01, "bw_mbps": null}}

Counters and, per configured period (phase), the added delay and the element's own timing error
(departure − planned release) go to ``impair_<name>_status.json`` in the output directory every
``status_period_s`` and at the end (percentiles at the end of each phase). SIGTERM or the end of
stdin stops it.
"""

from __future__ import annotations

import ctypes
import errno
import json
import os
import select
import signal
import socket
import struct
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from impairment.queue import Impairment, Phase, TimedQueue
from sdvisc.config import ClockSettings, ImpairNodeConfig, service_config
from sdvisc.jsonlines import JsonLineReader, write_json_atomic
from sdvisc.latest_writer import LatestWriter
from sdvisc.netns import raise_priority

ETH_P_ALL = 0x0003
SOL_PACKET = 263
PACKET_ADD_MEMBERSHIP = 1
PACKET_MR_PROMISC = 1
PACKET_IGNORE_OUTGOING = 23
PACKET_OUTGOING = 4
SO_TIMESTAMPNS = 35
SCM_TIMESTAMPNS = SO_TIMESTAMPNS
PR_SET_TIMERSLACK = 29
unpack_timespec = struct.Struct("qq").unpack_from
RT_PRIORITY = 11  # just above the plant and the SDC (10): the element's timing is the link's
DOWN_ERRNOS = (errno.ENETDOWN, errno.ENXIO, errno.ENODEV)
MAX_FRAME = 65536
WAKE_ON_ARRIVAL_BELOW_S = 2e-4  # below this much guaranteed delay, wake on every arrival (wall s)


def status_path(out_dir: str | Path, name: str) -> Path:
    return Path(out_dir) / f"impair_{name}_status.json"


def packet_socket(ifname: str) -> socket.socket:
    """A non-blocking raw socket on ``ifname``: every frame it receives, with its kernel receive
    time; promiscuous; frames this socket sends are not received back."""
    sock = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(ETH_P_ALL))
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
    sock.setsockopt(socket.SOL_SOCKET, SO_TIMESTAMPNS, 1)
    try:
        sock.setsockopt(SOL_PACKET, PACKET_IGNORE_OUTGOING, 1)
    except OSError:
        pass  # older kernels: outgoing frames are filtered by their packet type below
    sock.bind((ifname, ETH_P_ALL))
    mreq = struct.pack("iHH8s", socket.if_nametoindex(ifname), PACKET_MR_PROMISC, 0, b"")
    sock.setsockopt(SOL_PACKET, PACKET_ADD_MEMBERSHIP, mreq)
    sock.setblocking(False)
    return sock


def quiet_interface(ifname: str) -> None:
    """Offloads off (frames are forwarded as they are, never merged or left with partial
    checksums) and no IPv6 of its own on ``ifname``."""
    subprocess.run(["ethtool", "-K", ifname, "rx", "off", "tx", "off", "sg", "off", "tso", "off", "gso", "off",
                    "gro", "off"], capture_output=True, check=False)
    try:
        Path(f"/proc/sys/net/ipv6/conf/{ifname}/disable_ipv6").write_text("1")
    except OSError:
        pass


def tbf_args(ifname: str, bw_mbps: float | None, time_scale: float) -> list[str]:
    """The ``tc`` command that sets (or, for None, removes) the egress rate limit of ``ifname``:
    ``bw_mbps`` of simulated time is ``bw_mbps / time_scale`` of wall time; a burst of at least
    two full frames or 1 ms at the rate, a queue of 50 ms of simulated time."""
    if bw_mbps is None:
        return ["tc", "qdisc", "del", "dev", ifname, "root"]
    rate_bit = bw_mbps * 1e6 / time_scale
    burst = max(2 * 1514, int(rate_bit / 8 * 1e-3))
    return ["tc", "qdisc", "replace", "dev", ifname, "root", "tbf", "rate", f"{int(rate_bit)}bit",
            "burst", str(burst), "latency", f"{50 * time_scale:g}ms"]


def _set_timer_slack(ns: int = 1000) -> None:
    try:
        ctypes.CDLL(None).prctl(PR_SET_TIMERSLACK, ns, 0, 0, 0)
    except (OSError, AttributeError):
        pass


class Element:
    """The forwarding loop (see the module docstring)."""

    def __init__(self, cfg: ImpairNodeConfig) -> None:
        self.cfg = cfg
        self.clock = cfg.clock()
        self.name = cfg.name
        self._status_writer: LatestWriter | None = None  # periodic status, off the loop (write_status)
        self.directions = (f"{cfg.a}->{cfg.b}", f"{cfg.b}->{cfg.a}")
        self.impairment = Impairment(cfg.delay_ms, cfg.jitter_ms, cfg.loss, cfg.bw_mbps)
        for ifname in (cfg.intf_a, cfg.intf_b):
            quiet_interface(ifname)
        self.sock_a = packet_socket(cfg.intf_a)
        self.sock_b = packet_socket(cfg.intf_b)
        # frames received on a's side go to b (direction 0), and back
        self.queues = [TimedQueue(self.impairment, np.random.default_rng([cfg.seed, d])) for d in (0, 1)]
        self.routes = {self.sock_a.fileno(): (self.sock_a, 0), self.sock_b.fileno(): (self.sock_b, 1)}
        self.outputs = ((self.queues[0], self.sock_b, self.directions[0]),
                        (self.queues[1], self.sock_a, self.directions[1]))
        self.phases: list[Phase] = []
        self.phase = self._new_phase(self.clock.now())
        self.tc_errors: list[str] = []
        self._apply_bandwidth()
        self.commands = JsonLineReader(sys.stdin.fileno())
        self.scheduling = "default"
        self.started = self.clock.now()

    def _new_phase(self, t: float) -> Phase:
        phase = Phase(self.impairment, t, self.directions)
        self.phases.append(phase)
        return phase

    def _apply_bandwidth(self) -> None:
        for ifname in (self.cfg.intf_a, self.cfg.intf_b):
            args = tbf_args(ifname, self.impairment.bw_mbps, self.clock.time_scale)
            res = subprocess.run(args, capture_output=True, text=True, check=False)
            if res.returncode != 0 and self.impairment.bw_mbps is not None:
                self.tc_errors.append(f"{' '.join(args)}: {res.stderr.strip()}")

    def set_impairment(self, impairment: Impairment) -> None:
        now = self.clock.now()
        old_bw = self.impairment.bw_mbps
        self.phase.t_to = now
        self.impairment = impairment
        for q in self.queues:
            q.set(impairment)
        self.phase = self._new_phase(now)
        if impairment.bw_mbps != old_bw:
            self._apply_bandwidth()

    # ------------------------------------------------------------------ the loop
    def _receive(self, sock: socket.socket, direction: int) -> int:
        """Queue (or drop by loss) every frame waiting on ``sock``; returns how many there were."""
        queue = self.queues[direction]
        received = 0
        counts = self.phase.counts[self.directions[direction]]
        from_wall = self.clock.from_wall
        while True:
            try:
                frame, ancillary, _flags, address = sock.recvmsg(MAX_FRAME, 64)
            except BlockingIOError:
                return received
            except OSError as exc:  # ENETDOWN once when the interface went down
                if exc.errno in DOWN_ERRNOS:
                    return received
                raise
            if address[2] == PACKET_OUTGOING:
                continue
            received += 1
            if ancillary and ancillary[0][1] == SCM_TIMESTAMPNS:
                sec, nsec = unpack_timespec(ancillary[0][2])
                t_arrival = from_wall(sec + nsec * 1e-9)
            else:
                t_arrival = self.clock.now()
            counts["offered"] += 1
            if not queue.offer(frame, t_arrival):
                counts["dropped_loss"] += 1

    def _release(self) -> None:
        now_fn = self.clock.now
        phase = self.phase
        for queue, sock, direction in self.outputs:
            now = now_fn()
            for frame, t_arrival, t_release in queue.pop_due(now):
                t_sent = now_fn()
                try:
                    sock.send(frame)
                except OSError as exc:
                    key = "dropped_queue" if exc.errno == errno.ENOBUFS else "dropped_link_down"
                    if exc.errno not in DOWN_ERRNOS and exc.errno != errno.ENOBUFS:
                        raise
                    phase.counts[direction][key] += 1
                    continue
                phase.sent(direction, t_sent - t_arrival, t_sent - t_release)

    def _next_due_wall(self) -> float | None:
        due = [t for t in (q.next_release() for q in self.queues) if t is not None]
        return self.clock.to_wall(min(due)) if due else None

    def run(self) -> None:
        """Wake for the next release, for commands, and for arrivals only when an arrival could be
        due before the next wake-up: a frame arriving after a drain leaves no earlier than
        ``delay − jitter`` later, and its arrival time is the kernel's receive timestamp, so it
        may wait in the socket until then (one wake-up per frame instead of two)."""
        sockets = [self.sock_a.fileno(), self.sock_b.fileno()]
        stdin = [self.commands.fd]
        period = self.cfg.status_period_s
        spin_s = self.cfg.spin_us * 1e-6
        next_status = time.time()
        while True:
            drained = time.time()
            received = self._receive(self.sock_a, 0) + self._receive(self.sock_b, 1)
            if spin_s:
                due = self._next_due_wall()
                while due is not None and 0 < due - time.time() <= spin_s:
                    pass
            self._release()
            wall = time.time()
            if wall >= next_status:
                self.write_status(final=False)
                next_status = wall + period
            timeout = next_status - wall
            due = self._next_due_wall()
            if due is not None:
                timeout = min(timeout, max(0.0, due - wall - spin_s))
            imp = self.impairment
            quiet_s = self.clock.wall_s(max(0.0, imp.delay_s - imp.jitter_s)) - (wall - drained) - spin_s
            if quiet_s < WAKE_ON_ARRIVAL_BELOW_S or (due is None and not received):  # (idle: wait for traffic)
                ready, _, _ = select.select(sockets + stdin, [], [], timeout)
            else:
                ready, _, _ = select.select(stdin, [], [], min(timeout, quiet_s))
            if self.commands.fd in ready:
                for command in self.commands.read():
                    self.command(command)
                if not self.commands.open:
                    return

    def command(self, command: dict) -> None:
        if command.get("cmd") == "set":
            self.set_impairment(Impairment(**command["impairment"]))
        elif command.get("cmd") == "clock":  # the run's clock was set before t = 0 (time_scale: auto)
            self.clock = ClockSettings(time_scale=command["time_scale"], clock_epoch=command["clock_epoch"]).clock()
            for queue in self.queues:
                queue.drop_all()
                queue.last_release = float("-inf")
            self.set_impairment(self.impairment)
            self._apply_bandwidth()
        else:
            print(f"impair_node {self.name}: unknown command {command!r}", file=sys.stderr, flush=True)

    # ------------------------------------------------------------------ reporting
    def status(self, final: bool) -> dict:
        cpu = os.times()
        return {"name": self.name, "a": self.cfg.a, "b": self.cfg.b, "intf_a": self.cfg.intf_a, "intf_b": self.cfg.intf_b,
                "pid": os.getpid(), "scheduling": self.scheduling, "time_scale": self.clock.time_scale,
                "t": self.clock.now(), "t_started": self.started, "final": final,
                "current": self.impairment.as_dict(), "queued": [len(q) for q in self.queues],
                "cpu_s": round(cpu.user + cpu.system, 4), "tc_errors": self.tc_errors,
                "phases": [p.report(with_percentiles=final or p.t_to is not None) for p in self.phases]}

    def write_status(self, final: bool) -> None:
        """The periodic status goes to a writer thread: replacing a file on a busy ext4 can take tens
        of ms, and the element's loop is the link's timing. The final status is written in place,
        after the last periodic one."""
        if final:
            if self._status_writer is not None:
                self._status_writer.close()
            write_json_atomic(status_path(self.cfg.out_dir, self.name), self.status(final))
            return
        if self._status_writer is None:
            self._status_writer = LatestWriter(status_path(self.cfg.out_dir, self.name))
        self._status_writer.put(json.dumps(self.status(final), indent=1, sort_keys=True).encode())


def main(argv: list[str] | None = None) -> int:
    cfg = service_config(ImpairNodeConfig, argv, prog="python -m impairment.element", process="impairment element",
                         description=__doc__.split("\n")[0])
    signal.signal(signal.SIGTERM, lambda *_: (_ for _ in ()).throw(KeyboardInterrupt()))
    _set_timer_slack()
    element = Element(cfg)
    element.scheduling = raise_priority(RT_PRIORITY) if cfg.realtime_priority else "default"
    try:
        element.run()
    except KeyboardInterrupt:
        pass
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_IGN)  # stdin closed and SIGTERM come together: write once
        element.phase.t_to = element.clock.now()
        element.write_status(final=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
