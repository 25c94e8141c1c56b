"""The project's own external GTNET-SKT peer: an RTDS with GTNET-SKT cards, emulated, run as a
program of its own in place of the testbed's plant (``docs/wire-format.md``, "The project's
GTNET-SKT card emulator").

``python -m plant.card.emulator --config FILE`` (YAML or JSON, :class:`GtnetCardConfig`). One UDP socket
per turbine, bound to ``bind_ip`` and the turbine's port; a loop paced at ``step_s`` by its own
monotonic clock (step k at t0 + k·step_s·time_scale wall seconds; it sleeps to each deadline, spinning
only the last ``spin_us``); each step it reads everything waiting on every socket, hands it to
:class:`plant.card.core.CardCore` (the decisions, pure code) and sends what the core returns.
``gtnet_card_ready.json`` is written in ``out_dir`` once the sockets are bound, ``gtnet_card_stats.json``
at the end (SIGTERM, SIGINT or ``duration_s``). An invalid configuration ends it with status 2 and a
:class:`sdvisc.config.ConfigError` naming the file, the key and the problem.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
import time
from pathlib import Path

from plant.card.core import CardCore, GtnetCardConfig
from sdvisc.config import ConfigError, load_config
from sdvisc.jsonlines import write_json_atomic
from sdvisc.latest_writer import LatestWriter
from sdvisc.netns import udp_socket_in

READY_FILE = "gtnet_card_ready.json"
STATS_FILE = "gtnet_card_stats.json"
STATUS_FILE = "gtnet_card_status.json"
"""The card's live status (simulated time, late steps, packets, streaming turbines), every
:data:`STATUS_EVERY_S` of card time: what a run's progress line shows (as the plant's ``plant_status.json``)."""
STATUS_EVERY_S = 0.05
MAX_READ_PER_STEP = 4096
"""At most this many datagrams read from one socket per step (the first ``flood_limit_per_step`` are
handled, the rest counted as ``flood``); what a flood leaves waiting is read in the next steps."""


def load_card_config(path: str | Path) -> GtnetCardConfig:
    """Read and validate a card configuration (:func:`sdvisc.config.load_config`: YAML for .yaml/.yml,
    else JSON; every problem with its key, and its line in YAML)."""
    return load_config(GtnetCardConfig, path)


class GtnetCard:
    """The sockets and the paced loop around :class:`CardCore` (``self.core``)."""

    def __init__(self, cfg: GtnetCardConfig) -> None:
        self.cfg = cfg
        self.clock = cfg.clock()  # header stamps and AK timing (the run's clock, simulated seconds)
        self.core = CardCore(cfg)
        self._status = LatestWriter(Path(cfg.out_dir) / STATUS_FILE)
        self.socks = []
        try:
            for t in cfg.turbines:
                self.socks.append(udp_socket_in(None, cfg.bind_ip, t.port))
        except OSError:
            self.close()
            raise
        self.stop_requested = False
        self.t0_wall: float | None = None  # the run clock's reading at step 0 (set by start)
        self._t0_mono = 0.0
        self.late_steps = 0
        self.max_lateness_s = 0.0
        self.wall_s = 0.0
        self.cpu_s = 0.0

    def request_stop(self, *_) -> None:
        self.stop_requested = True

    def _drain(self, now: float) -> None:
        core = self.core
        for i, sock in enumerate(self.socks):
            for _ in range(MAX_READ_PER_STEP):
                try:
                    data, addr = sock.recvfrom(2048)
                except BlockingIOError:
                    break
                except OSError:  # e.g. an ICMP error reported on the socket
                    core.socket_error(i)
                    break
                core.receive(i, data, addr, now)

    def _send(self, out) -> None:
        socks = self.socks
        for i, kind, data, addr in out:
            try:
                socks[i].sendto(data, addr)
            except OSError:
                self.core.send_failed(i, kind)

    def _wait_until(self, deadline: float) -> None:
        """Sleep until the monotonic clock reads ``deadline``; busy-wait only the last ``spin_us``."""
        spin = self.cfg.spin_us * 1e-6
        rest = deadline - time.monotonic() - spin
        if rest > 0:
            time.sleep(rest)
        while spin and time.monotonic() < deadline:
            pass

    def start(self) -> float:
        """Fix t = 0 (step 0) at now; returns the run clock's reading then (``t0_wall``)."""
        self._t0_mono = time.monotonic()
        self.t0_wall = self.clock.now()
        return self.t0_wall

    def run(self) -> None:
        """The paced loop from step 0 (:meth:`start`, if not called yet: now) until ``duration_s`` or a stop."""
        cfg, core, clock = self.cfg, self.core, self.clock
        step_wall = cfg.step_s * cfg.time_scale
        end = core.n_steps if core.n_steps is not None else float("inf")
        cpu0 = time.process_time()
        if self.t0_wall is None:
            self.start()
        t0 = self._t0_mono
        status_every = max(1, int(round(STATUS_EVERY_S / cfg.step_s)))
        while core.k < end and not self.stop_requested:
            deadline = t0 + core.k * step_wall
            if time.monotonic() < deadline:
                self._wait_until(deadline)
            lateness = (time.monotonic() - deadline) / cfg.time_scale  # simulated seconds
            if lateness > cfg.step_s:
                self.late_steps += 1
            self.max_lateness_s = max(self.max_lateness_s, lateness)
            now = clock.now()
            self._drain(now)
            self._send(core.step(now))
            if core.k % status_every == 0:
                self._status.put(json.dumps(self.status()).encode())
        self.wall_s = time.monotonic() - t0
        self.cpu_s = time.process_time() - cpu0

    def status(self) -> dict:
        """The live status (:data:`STATUS_FILE`)."""
        totals = [p.counts for p in self.core.ports]
        return {"t_sim": round(self.core.k * self.cfg.step_s, 6), "late_steps": self.late_steps,
                "meas_tx": sum(c["meas_tx"] for c in totals), "ctrl_rx": sum(c["ctrl_rx"] for c in totals),
                "streaming": [p.name for p in self.core.ports if p.streaming]}

    def summary(self) -> dict:
        """What ``gtnet_card_stats.json`` holds: the core's counters and the pacing."""
        return {**self.core.summary(), "late_steps": self.late_steps,
                "max_lateness_ms": round(self.max_lateness_s * 1e3, 3), "time_scale": self.cfg.time_scale,
                "wall_s": round(self.wall_s, 3), "cpu_s": round(self.cpu_s, 3), "t0_wall": self.t0_wall}

    def close(self) -> None:
        for sock in self.socks:
            sock.close()
        self._status.close()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m plant.card.emulator", description=__doc__.split("\n\n")[0])
    parser.add_argument("--config", required=True, help="the card's configuration, YAML or JSON")
    args = parser.parse_args(argv)
    try:
        cfg = load_card_config(args.config)
    except ConfigError as exc:
        print(f"gtnet_card: {exc}", file=sys.stderr)
        return 2
    out_dir = Path(cfg.out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    try:
        card = GtnetCard(cfg)
    except OSError as exc:
        print(f"gtnet_card: cannot bind the turbine ports on {cfg.bind_ip}: {exc}", file=sys.stderr)
        return 1
    signal.signal(signal.SIGTERM, card.request_stop)
    signal.signal(signal.SIGINT, card.request_stop)
    write_json_atomic(out_dir / READY_FILE, {
        "pid": os.getpid(), "bind_ip": cfg.bind_ip, "framing": cfg.framing, "stream": cfg.stream,
        "ports": {t.name: t.port for t in cfg.turbines}, "t0_wall": card.start()})
    try:
        card.run()
    finally:
        card.close()
        write_json_atomic(out_dir / STATS_FILE, card.summary())
    return 0



if __name__ == "__main__":
    sys.exit(main())
