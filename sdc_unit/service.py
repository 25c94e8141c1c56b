"""The SDC unit as a network service: ``python -m sdc_unit.service --config FILE``, run inside an
SDC Mininet host.

A thin shim around the pure :class:`sdc_unit.core.SdcCore`, which makes every decision (commands,
admission, the sequence gate, stepping, CTRL encoding, heartbeat content; see there). Here only
what a process does: the UDP socket on ``wire.PORT_SDC`` (read everything waiting, send what the
core hands back, count what could not be sent), the wait for a datagram or for :meth:`SdcService.stop`
(an eventfd; SIGTERM/SIGINT call it), the gathering of one sample's measurements
(:mod:`sdc_unit.gather`, ``gather_steps``), the heartbeat timer (its own thread, every
:data:`HEARTBEAT_S`), the run's clock, and the ready and stats files: ``sdc<id>_stats.json`` is
written as the SDC goes (every :data:`STATS_PERIOD_S`, a snapshot of the counts, ``"final": false``)
and in full when it stops (``"final": true``), so an SDC killed with SIGKILL leaves its counts up
to its last snapshot (issue 42).
"""

from __future__ import annotations

import json
import os
import select
import signal
import socket
import sys
import threading
import time
from pathlib import Path

from sdc_unit.core import Output, SdcCore
from sdc_unit.gather import gather
from sdvisc import wire
from sdvisc.config import SdcConfig, service_config
from sdvisc.jsonlines import write_json_atomic
from sdvisc.latest_writer import LatestWriter
from sdvisc.netns import raise_priority

HEARTBEAT_S = 0.01
IDLE_WAIT_S = 0.5
"""Wall seconds the main loop waits for a datagram before it looks at ``until`` again (:meth:`SdcService.stop`
ends the wait at once). Nothing else in the loop is timed: the heartbeats have their own thread, so
an idle SDC wakes only for them (it woke every 5 ms before, ~12 µs of CPU per plant step)."""
STATS_PERIOD_S = 0.2
"""Wall seconds between two snapshots of the stats file while the SDC serves (:meth:`SdcService.snapshot`):
at most what a SIGKILL loses. The loop looks once per wake-up; the snapshot (the counts as JSON,
written by a :class:`sdvisc.latest_writer.LatestWriter` thread, never waiting for the disk) costs
well under 1 % of a core at this period (benchmarks/sdc_stats_snapshot.py)."""


class SdcService:
    """The process around an :class:`sdc_unit.core.SdcCore` (see the module docstring)."""

    def __init__(self, cfg: SdcConfig, sock: socket.socket | None = None) -> None:
        self.cfg = cfg
        self.clock = cfg.clock()
        self.core = SdcCore(cfg)
        self.sock = sock or self._open_socket(cfg.bind_ip)
        self.gather_wall_s = self.clock.wall_s(cfg.gather_steps * cfg.step_s)
        self.gathered = 0  # datagrams read while waiting for the rest of a sample
        self.gather_incomplete = 0  # waits the window ended before every streaming turbine's MEAS came
        self.running = True
        self.stats_writer: LatestWriter | None = None  # main(): snapshots of the stats file as it goes
        self._next_snapshot = 0.0  # time.monotonic() of the next one
        self._wake_fd = -1  # run()'s eventfd while it runs, written by stop(): ends the idle wait

    # the core's state, read-only views (tests, the pilot, the benchmarks)
    bank = property(lambda self: self.core.bank)
    instances = property(lambda self: self.core.instances)
    rejected = property(lambda self: self.core.rejected)
    rx_stats = property(lambda self: self.core.rx_stats)
    events = property(lambda self: self.core.events)
    sdc_id = property(lambda self: self.core.sdc_id)

    def stop(self) -> None:
        """End :meth:`run` (callable from a signal handler or another thread): the loop's wait ends
        at once, the round in progress is finished."""
        self.running = False
        if self._wake_fd >= 0:  # (-1: run() is not running)
            os.eventfd_write(self._wake_fd, 1)

    @staticmethod
    def _open_socket(bind_ip: str) -> socket.socket:
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 21)
        sock.bind((bind_ip, wire.PORT_SDC))
        sock.setblocking(False)
        return sock

    # ------------------------------------------------------------------ datagrams in and out
    def serve(self, datagrams: list[tuple[bytes, tuple]], now: float, read_at: list[float] | None = None) -> Output:
        """Hand ``datagrams`` to the core (:meth:`sdc_unit.core.SdcCore.handle`) and send what it answers."""
        out = self.core.handle(datagrams, now, read_at)
        sendto = self.sock.sendto
        for data, addr, owner in out.sends:
            try:
                sendto(data, addr)
            except OSError:
                self.core.send_failed(owner)
        for text in out.log:
            print(text, file=sys.stderr)
        return out

    def _read_waiting(self) -> list[tuple[bytes, tuple]]:
        """Every datagram waiting on the socket."""
        datagrams: list[tuple[bytes, tuple]] = []
        while True:
            try:
                datagrams.append(self.sock.recvfrom(2048))
            except BlockingIOError:
                break
            except OSError:  # e.g. an ICMP error queued on the socket: nothing to read, go on
                self.core.rejected["socket_error"] += 1
                break
        return datagrams

    def wake(self, now: float, poller=None) -> None:
        """One wake-up: read every waiting datagram, wait (with ``poller``, up to the gather window)
        for the rest of the sample's measurements (:func:`sdc_unit.gather.gather`), and serve them.
        ``now``: when the wake-up began (the read time of what was waiting); the answers are
        stamped when they are made."""
        first = self._read_waiting()
        if not first:
            return
        if self.gather_wall_s <= 0:
            self.serve(first, now)
            return
        datagrams, read_at = first, [now] * len(first)
        if poller is not None:
            def read_more(timeout_s: float) -> list[tuple[bytes, tuple]]:
                return self._read_waiting() if poller.poll(timeout_s) else []

            datagrams, read_at, complete = gather(first, now, read_more, self.core.is_meas,
                                                  self.core.streaming(now), self.gather_wall_s, now=self.clock.now)
            self.gathered += len(datagrams) - len(first)
            self.gather_incomplete += not complete
        self.serve(datagrams, self.clock.now(), read_at)

    # ------------------------------------------------------------------ the process
    def _heartbeat_loop(self) -> None:
        """Heartbeats from their own thread: they say the process is alive even while the main loop
        works through a burst (a dead process stops them at once; a stuck loop shows in the AKs)."""
        while self.running:
            data, addr = self.core.heartbeat(self.clock.now())
            try:
                self.sock.sendto(data, addr)
            except OSError:
                pass
            self.clock.sleep(HEARTBEAT_S)

    def run(self, until: float | None = None) -> None:
        self._wake_fd = os.eventfd(0, os.EFD_NONBLOCK | os.EFD_CLOEXEC)
        poller = select.epoll()  # the socket alone (the gather window waits on it)
        poller.register(self.sock.fileno(), select.EPOLLIN)
        waiter = select.epoll()  # the socket or stop()
        waiter.register(self.sock.fileno(), select.EPOLLIN)
        waiter.register(self._wake_fd, select.EPOLLIN)
        beats = threading.Thread(target=self._heartbeat_loop, name="heartbeat", daemon=True)
        beats.start()
        try:
            while self.running and (until is None or time.time() < until):  # until: wall time
                waiter.poll(IDLE_WAIT_S if until is None else min(IDLE_WAIT_S, max(0.0, until - time.time())))
                # the run's one clock: stamps, delays and events in simulated seconds
                self.wake(self.clock.now(), poller)
                woke = time.monotonic()
                if self.stats_writer is not None and woke >= self._next_snapshot:
                    self._next_snapshot = woke + STATS_PERIOD_S
                    self.stats_writer.put(json.dumps(self.snapshot()).encode())
        finally:
            self.running = False
            beats.join(timeout=1.0)
            poller.close()
            waiter.close()
            fd, self._wake_fd = self._wake_fd, -1
            os.close(fd)

    def snapshot(self) -> dict:
        """The stats file while the SDC serves: :meth:`summary` without its delay percentiles, ``final``
        False, ``t_written`` (run clock)."""
        return {"final": False, "t_written": self.clock.now()} | self.core.summary(self._shim_counts(), delays=False)

    def _shim_counts(self) -> dict:
        return {"gather_window_wall_s": self.gather_wall_s, "gathered": self.gathered,
                "gather_incomplete": self.gather_incomplete}

    def summary(self) -> dict:
        return {"final": True, "t_written": self.clock.now()} | self.core.summary(self._shim_counts())


def main(argv: list[str] | None = None) -> int:
    cfg = service_config(SdcConfig, argv, prog="python -m sdc_unit.service", process="sdc", description=__doc__)
    service = SdcService(cfg)
    service.bank.warm_up()  # also loads (or, the first time on a machine, compiles) the Tustin step
    if cfg.realtime_priority:
        raise_priority()
    out_dir = Path(cfg.out_dir)  # the runner starts the plant only when every SDC is ready
    write_json_atomic(out_dir / f"sdc{service.sdc_id}_ready.json", {"t_ready": time.time()})

    def stop(*_):
        service.stop()

    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)
    stats_path = out_dir / f"sdc{service.sdc_id}_stats.json"
    service.stats_writer = LatestWriter(stats_path)
    try:
        service.run()
    finally:
        service.stats_writer.close()  # its last snapshot first: the full statistics replace it
        write_json_atomic(stats_path, service.summary())
    return 0


if __name__ == "__main__":
    sys.exit(main())
