"""The real-time plant service: one process paces the plant model to the wall clock and serves
every turbine's GTNET-SKT endpoint from inside that turbine's Mininet host.

``python -m plant.service --config FILE`` (the runner writes FILE). What the turbines do with the
packets is the pure core, :class:`plant.service.core.PlantCore`: a turbine starts streaming
measurements to its SDC only when the SDN application tells it to (``REQUEST STREAM_START``, which
also names the SDC); from then on, each step it sends one ``MEAS``, applies the newest ``CTRL`` it
received (hold last value; fall back after the model's loss time), and reports ``AK`` (1 when a
``CTRL`` arrived within ``ak_window_s``) to the SDN application every ``ak_period_s`` and at once
whenever it changes. Malformed, unexpected or implausible packets are dropped and counted by
reason, never applied (:mod:`plant.service.endpoint_rx`); a MEAS the wire cannot carry (a non-finite value
of a diverged model) is counted (``meas_unencodable``) and not sent (:mod:`plant.service.endpoint_tx`).

The model is whatever ``plant.model`` names, behind one interface (:class:`plant.backend.PlantBackend`:
the phasor farm, the infinite bus, the EMT arrangement on DPsim). This module is the shim around it: per turbine one UDP socket in the turbine host's network
namespace (bound to the turbine IP, port ``wire.PORT_TURBINE``), the loop paced to the run's clock
(wall or virtual), the scenario events arriving as JSON lines on stdin (``{"type": "stop"}`` ends
the run; without ``duration_s`` the plant runs until then), the recorder (``timeseries.csv``), the
live status and event files (:mod:`plant.service.live`), signals, and ``plant_stats.json`` at the end
(:mod:`plant.service.summary`).
"""

from __future__ import annotations

import json
import select
import signal
import sys
import time
from pathlib import Path

from plant.backend import close_backend
from plant.service.core import Pacing, PlantCore
from plant.service.live import STATUS_EVERY_S, LivePublisher
from plant.service.model import build_model
from plant.service.recorder import Recorder
from plant.service.summary import summarise
from sdvisc import wire
from sdvisc.config import PlantConfig, service_config
from sdvisc.jsonlines import JsonLineReader, write_json_atomic
from sdvisc.netns import raise_priority, udp_socket_in


class PlantService:
    """The sockets, the paced loop and the files around the turbines' core (``self.core``, a
    :class:`~plant.service.core.PlantCore`)."""

    def __init__(self, cfg: PlantConfig) -> None:
        self.cfg = cfg
        self.clock = cfg.clock()  # the run's one clock: pacing, AK timing, header stamps, delays
        self.step_s = cfg.step_s
        self.out_dir = Path(cfg.out_dir)
        model, indices = build_model(cfg, [t.name for t in cfg.turbines])
        self.live = LivePublisher(self.out_dir, [])
        self.core = PlantCore(cfg, model, indices, self.live)
        self.pacing = Pacing(self.step_s)
        self.socks = {}  # endpoint name -> its socket
        self.by_fd = {}  # socket fd -> (endpoint, socket)
        for t, ep in zip(cfg.turbines, self.core.endpoints):
            sock = udp_socket_in(t.pid, t.ip, wire.PORT_TURBINE)
            self.socks[ep.name] = sock
            self.by_fd[sock.fileno()] = (ep, sock)
        self.recorder = Recorder(self.out_dir / "timeseries.csv",
                                 [ep for ep in self.core.endpoints if ep.name in cfg.record],
                                 every=cfg.record_every, batteries=self.core.batteries)
        self.poller = select.epoll()
        for fd in self.by_fd:
            self.poller.register(fd, select.EPOLLIN)
        self.commands = JsonLineReader(sys.stdin.fileno()) if cfg.stdin_commands else None
        if self.commands is not None:
            self.poller.register(self.commands.fd, select.EPOLLIN)
        self.scheduling = "default"
        self.cpu_s = 0.0

    # ------------------------------------------------------------------ receive
    def _drain(self, now: float) -> None:
        """Hand every waiting datagram and command to the core (which applies the newest control
        output per turbine at its next step)."""
        core = self.core
        for fd, _ in self.poller.poll(0):
            if self.commands is not None and fd == self.commands.fd:
                for event in self.commands.read():
                    core.apply_event(event)
                if not self.commands.open:
                    self.poller.unregister(self.commands.fd)
                    self.commands = None
                continue
            ep, sock = self.by_fd[fd]
            while True:
                try:
                    data, addr = sock.recvfrom(2048)
                except BlockingIOError:
                    break
                except OSError:  # e.g. an ICMP error reported on the socket: nothing to read now
                    core.socket_error(ep)
                    break
                core.receive(ep, data, addr, now)

    def _send(self, out) -> None:
        socks = self.socks
        for ep, data, addr in out:
            try:
                socks[ep.name].sendto(data, addr)
            except OSError:
                self.core.send_failed(ep, addr)

    # ------------------------------------------------------------------ loop
    def run(self) -> None:
        clock, core, pacing = self.clock, self.core, self.pacing
        t0 = float(self.cfg.t0_wall or clock.now())
        self.live.t0 = t0
        cpu_at_start = time.process_time()
        status_every = max(1, int(STATUS_EVERY_S / self.step_s))
        end = core.n_steps if core.n_steps is not None else float("inf")
        while core.k < end and not core.stop_requested:
            scheduled = t0 + core.k * self.step_s  # every time here is the run's clock (simulated seconds)
            now = clock.now()
            if now < scheduled:
                now = clock.sleep_until(scheduled)
            pacing.note(core.k, now - scheduled)
            self._drain(now)
            self._send(core.step(now))
            self.recorder.maybe_record(core.k, core.model)
            if core.k % status_every == 0:
                self.live.check_losses(core.endpoints, now)
                self.live.write_status(core, now, pacing.late_steps)
        self.live.write_status(core, clock.now(), pacing.late_steps)
        self.cpu_s = time.process_time() - cpu_at_start  # from t = 0: what the paced loop cost

    def summary(self) -> dict:
        """What plant_stats.json holds (:func:`plant.service.summary.summarise`)."""
        return summarise(self.core, self.pacing, self.recorder.extremes(), scheduling=self.scheduling,
                         cpu_s=self.cpu_s)

    def close(self) -> None:
        close_backend(self.core.model)  # what the model holds (the EMT backend: DPsim's simulation)
        self.recorder.close()
        self.live.close()
        for sock in self.socks.values():
            sock.close()
        self.poller.close()


def main(argv: list[str] | None = None) -> int:
    cfg = service_config(PlantConfig, argv, prog="python -m plant.service", process="plant", description=__doc__)
    signal.signal(signal.SIGTERM, lambda *_: (_ for _ in ()).throw(KeyboardInterrupt()))
    service = PlantService(cfg)  # builds the model (loads, or the first time compiles, its code)
    service.scheduling = raise_priority() if cfg.realtime_priority else "default"
    if cfg.t0_wall is None and cfg.start_margin_wall_s is not None:
        # the runner waits for this: t = 0 is set only once the model is ready, so a slow start
        # (numba's cache loading, a first compile) does not show up as late steps
        cfg.t0_wall = service.clock.from_wall(time.time() + cfg.start_margin_wall_s)
        write_json_atomic(Path(cfg.out_dir) / "plant_ready.json", {"t0_wall": cfg.t0_wall})
    try:
        service.run()
    except KeyboardInterrupt:
        pass
    finally:
        service.close()
        (Path(cfg.out_dir) / "plant_stats.json").write_text(json.dumps(service.summary(), indent=1))
    return 0

