"""The real-time plant service: one process paces the plant model to the wall clock and serves
every turbine's GTNET-SKT endpoint from inside that turbine's Mininet host.

``python -m plant.service --config FILE`` (the runner writes FILE). Per turbine it opens one UDP
socket in the turbine host's network namespace (bound to the turbine IP, port
``wire.PORT_TURBINE``). A turbine starts streaming measurements to its SDC only when the SDN
application tells it to (``REQUEST STREAM_START``, which also names the SDC); from then on, each
step it sends one ``MEAS``, applies the newest ``CTRL`` it received (hold last value; fall back
after the model's loss time), and reports ``AK`` (1 when a ``CTRL`` arrived within
``ak_window_s``) to the SDN application every ``ak_period_s`` and at once whenever it changes. Scenario events arrive as JSON lines on stdin
(``{"type": "stop"}`` ends the run; without ``duration_s`` the plant runs until then). While it runs
it publishes its status and events (:mod:`plant.live`).
Malformed, unexpected or implausible packets are dropped and counted by reason, never applied
(:mod:`plant.endpoint_rx`); a MEAS the wire cannot carry (a non-finite value of a diverged model)
is counted (``meas_unencodable``) and not sent (:mod:`plant.endpoint_tx`).
"""

from __future__ import annotations

import argparse
import json
import select
import signal
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from plant import endpoint_rx
from plant.endpoint_tx import MeasPacker
from plant.live import STATUS_EVERY_S, LivePublisher
from plant.recorder import Recorder
from plant.service_model import FARM_TURBINES_PER_CLUSTER, apply_set, build_model, farm_index  # noqa: F401 (re-exported)
from plant.service_summary import summarise
from sdvisc import wire
from sdvisc.config import ConfigError, PlantConfig, load_config
from sdvisc.jsonlines import JsonLineReader, write_json_atomic
from sdvisc.netns import raise_priority, udp_socket_in
from sdvisc.vocabulary import MEAS_FIELDS

RTT_BINS = 8
CTRL_GAP_STEPS = 2.5  # a pause between control packets longer than this many steps is recorded (>= 2 missing)
MAX_CTRL_GAPS = 100_000  # per turbine (a long run on a loaded machine at k = 1)


@dataclass
class Endpoint:
    """One turbine's network endpoint and its packet counters."""

    name: str
    wid: int
    index: int
    sock: object
    streaming: bool = False
    sdc_addr: tuple[str, int] | None = None
    meas_seq: int = 0
    ak_seq: int = 0
    ctrl_seq: int = -1
    last_ctrl_wall: float = float("-inf")
    counts: dict = field(default_factory=lambda: {"meas_tx": 0, "ctrl_rx": 0, "ak_tx": 0, "ctrl_stale": 0,
                                                  "rx_rejected": 0, "requests_rx": 0})
    first_meas_tx_t: float | None = None
    first_ctrl_rx_t: float | None = None
    last_ctrl_rx_t: float | None = None
    ctrl_delays_ms: list = field(default_factory=list)
    ak_ones: int = 0
    last_ak_sent: int = -1
    loss_reported: bool = False  # an AK has said that the current loss lasted report_loss_after_s
    ctrl_gaps: list = field(default_factory=list)
    ctrl_own_seq: int = -1  # the newest CTRL's own seq (the SDC instance's counter)
    ctrl_resumed: list = field(default_factory=list)  # [send time, CTRL lost before it]: where a loss ended
    last_v_ref: complex | None = None
    last_delta: float = float("nan")  # the newest applied CTRL's virtual rotor angle (rad) and
    last_e_mag: float = float("nan")  # internal EMF magnitude (p.u.), for timeseries.csv
    backup_seen: bool = False
    takeover_jump: float | None = None
    # CTRL answers by round trip in samples: [1, 2, …, RTT_BINS-1, more] (1 = applied in the step
    # right after the MEAS it answers: the paper's one-sample loop delay)
    rtt_samples: list = field(default_factory=lambda: [0] * RTT_BINS)
    awaiting_first_ctrl: bool = False  # streaming started, no control packet yet (plant.live)
    stream_started_wall: float = 0.0
    ctrl_lost_reported: bool = False
    live_delay: list = field(default_factory=lambda: [0.0, 0])  # sum (ms) and count since the last status


class PlantService:
    """The paced loop; see the module docstring."""

    def __init__(self, cfg: PlantConfig) -> None:
        self.cfg = cfg
        self.clock = cfg.clock()  # the run's one clock: pacing, AK timing, header stamps, delays
        self.step_s = cfg.step_s
        self.n_steps = int(round(cfg.duration_s / self.step_s)) if cfg.duration_s is not None else None  # None: until stopped
        self.header = cfg.header
        self.vip = cfg.controller_vip
        self.ak_every = max(1, int(round(cfg.ak_period_s / self.step_s)))
        self.ak_window_s = cfg.ak_window_s
        self.report_loss_after_s = cfg.report_loss_after_s
        self.out_dir = Path(cfg.out_dir)
        self.model, indices = build_model(cfg, [t.name for t in cfg.turbines])
        self.endpoints: list[Endpoint] = []
        for t, index in zip(cfg.turbines, indices):
            sock = udp_socket_in(t.pid, t.ip, wire.PORT_TURBINE)
            self.endpoints.append(Endpoint(t.name, t.wid, index, sock))
        self.by_fd = {ep.sock.fileno(): ep for ep in self.endpoints}
        self.streaming: list[Endpoint] = []  # the endpoints streaming, in endpoint order (kept by _on_request)
        self.rx_stats = wire.DecodeStats()
        self.meas_packer = MeasPacker(self.header)
        self.check_rx_source = cfg.check_rx_source  # see plant.endpoint_rx
        self.late_steps = 0
        self.stalls: list[list] = []  # [t_sim at the start, worst lateness ms, last step] of each stall > 10 ms
        self.max_lateness_s = 0.0
        self.k = 0
        self.events_applied: list[dict] = []
        self.batteries = {name: farm_index(name, self.model.n) for name in cfg.batteries}
        self.soc_start = {name: float(self.model.tb.batt.soc[i]) for name, i in self.batteries.items()}
        self.recorder = Recorder(self.out_dir / "timeseries.csv", [ep for ep in self.endpoints if ep.name in cfg.record],
                                 every=cfg.record_every, batteries=self.batteries)
        self.poller = select.epoll()
        for fd in self.by_fd:
            self.poller.register(fd, select.EPOLLIN)
        self.commands = JsonLineReader(sys.stdin.fileno()) if cfg.stdin_commands else None
        if self.commands is not None:
            self.poller.register(self.commands.fd, select.EPOLLIN)
        self.stop_requested = False
        self.live = LivePublisher(self.out_dir, self.events_applied)

    # ------------------------------------------------------------------ receive
    def _drain(self, now: float) -> None:
        """Read every waiting datagram and command; the newest control output per turbine is then
        applied to the model in one vectorised call."""
        newest: dict[int, wire.Message] = {}
        for fd, _ in self.poller.poll(0):
            if self.commands is not None and fd == self.commands.fd:
                for event in self.commands.read():
                    self._apply_event(event)
                if not self.commands.open:
                    self.poller.unregister(self.commands.fd)
                    self.commands = None
                continue
            ep = self.by_fd[fd]
            while True:
                try:
                    data, addr = ep.sock.recvfrom(2048)
                except BlockingIOError:
                    break
                except OSError:  # e.g. an ICMP error reported on the socket: nothing to read now
                    ep.counts["rx_socket_error"] = ep.counts.get("rx_socket_error", 0) + 1
                    break
                try:  # one bad datagram never stops the loop
                    action, msg = endpoint_rx.receive(ep, data, addr, header=self.header, controller_ip=self.vip,
                                                      stats=self.rx_stats, check_source=self.check_rx_source)
                    if action == endpoint_rx.APPLY:
                        self._on_ctrl(ep, msg, now)
                        if ep.streaming:
                            newest[ep.index] = msg
                    elif action == endpoint_rx.REQUEST:
                        self._on_request(ep, msg, now)
                except Exception as error:  # noqa: BLE001 - counted and logged once
                    endpoint_rx.count_internal(ep.counts, error)
        if newest:
            index = np.fromiter(newest, dtype=np.intp, count=len(newest))
            refs = np.array([[m["v_ref_d"], m["v_ref_q"], m["i_ref_d"], m["i_ref_q"]] for m in newest.values()],
                            dtype=np.float64).T.copy()  # one contiguous row per reference
            self.model.apply_remote(index, refs[0], refs[1], refs[2], refs[3])

    def _on_ctrl(self, ep: Endpoint, msg: wire.Message, now: float) -> None:
        """Account for one CTRL that :func:`plant.endpoint_rx.receive` accepted (the newest so far)."""
        ep.counts["ctrl_rx"] += 1
        rtt = ep.meas_seq - int(msg["meas_seq"])  # 0: answers the MEAS sent at the end of the last step
        ep.rtt_samples[min(max(rtt, 0), RTT_BINS - 1)] += 1
        if (ep.last_ctrl_wall > float("-inf") and now - ep.last_ctrl_wall > CTRL_GAP_STEPS * self.step_s
                and len(ep.ctrl_gaps) < MAX_CTRL_GAPS):
            ep.ctrl_gaps.append((ep.last_ctrl_wall, now))
        v_ref = complex(msg["v_ref_d"], msg["v_ref_q"])
        from_backup = bool(msg["flags"] & 2)
        if from_backup and not ep.backup_seen:
            ep.backup_seen = True
            ep.takeover_jump = abs(v_ref - ep.last_v_ref) if ep.last_v_ref is not None else None
        ep.last_v_ref = v_ref
        ep.last_delta, ep.last_e_mag = float(msg["delta"]), float(msg["e_mag"])
        self.live.on_ctrl(ep, now)
        ep.last_ctrl_wall = now
        ep.loss_reported = False
        t_sim = self.k * self.step_s
        ep.last_ctrl_rx_t = t_sim
        if ep.first_ctrl_rx_t is None:
            ep.first_ctrl_rx_t = t_sim
        own_seq = msg["seq"]
        if msg.header is not None:
            sent = msg.header.sec + msg.header.nsec * 1e-9
            if 0 <= ep.ctrl_own_seq < own_seq - 1 and len(ep.ctrl_resumed) < MAX_CTRL_GAPS:
                ep.ctrl_resumed.append([round(sent, 6), own_seq - ep.ctrl_own_seq - 1])  # the SDC sent, the path lost
            delay_ms = (now - sent) * 1e3
            ep.live_delay[0] += delay_ms
            ep.live_delay[1] += 1
            if len(ep.ctrl_delays_ms) < 200_000:
                ep.ctrl_delays_ms.append(delay_ms)
        ep.ctrl_own_seq = own_seq

    def _on_request(self, ep: Endpoint, msg: wire.Message, now: float) -> None:
        """Carry out a STREAM_START/STREAM_STOP that :func:`plant.endpoint_rx.receive` accepted."""
        ep.counts["requests_rx"] += 1
        cmd = msg["cmd"]
        t_sim = self.k * self.step_s
        if cmd == wire.Command.STREAM_START:
            if not ep.streaming:
                ep.awaiting_first_ctrl = True
                ep.stream_started_wall = now
            ep.streaming = True
            self.streaming = [e for e in self.endpoints if e.streaming]
            ep.sdc_addr = (wire.i32_to_ip(msg["sdc_ip"]), wire.PORT_SDC)
            self.model.set_mode(ep.index, "remote")
            self.live.event({"t": t_sim, "type": "stream_start", "wt": ep.name, "sdc": ep.sdc_addr[0]})
        elif cmd == wire.Command.STREAM_STOP:
            ep.streaming = False
            self.streaming = [e for e in self.endpoints if e.streaming]
            self.model.set_mode(ep.index, "grid_following")
            self.live.event({"t": t_sim, "type": "stream_stop", "wt": ep.name})

    def _apply_event(self, event: dict) -> None:
        kind = event["type"]
        m = self.model
        if kind == "stop":
            self.stop_requested = True
        elif kind == "load_step":
            m.load_step(float(event["mw"]))
        elif kind == "fault":
            m.fault(bool(event.get("on", True)))
        elif kind == "scr":
            m.set_scr(float(event["value"]))
        elif kind == "set":
            event = {**event, **apply_set(m, event)}  # a delta: the value it came to, recorded
        else:
            raise ValueError(f"plant cannot apply event {kind!r}")
        self.live.event({"t": self.k * self.step_s, **event})

    # ------------------------------------------------------------------ send
    def _send(self, now: float) -> None:
        streaming = self.streaming
        if not streaming:
            return
        meas = self.model.measurements()
        columns = [meas[key] for key in MEAS_FIELDS]
        t_sim = self.k * self.step_s
        sec = int(now)
        nsec = int((now - sec) * 1e9)
        send_ak = self.k % self.ak_every == 0
        pack = self.meas_packer.pack
        for ep in streaming:
            i = ep.index
            ep.meas_seq += 1
            data = pack(ep.wid, ep.meas_seq, t_sim, [float(column[i]) for column in columns], sec, nsec)
            if data is None:  # a value the wire cannot carry (the model diverged): counted, not sent
                ep.counts["meas_unencodable"] = ep.counts.get("meas_unencodable", 0) + 1
            else:
                try:
                    ep.sock.sendto(data, ep.sdc_addr)
                    ep.counts["meas_tx"] += 1
                    if ep.first_meas_tx_t is None:
                        ep.first_meas_tx_t = t_sim
                except OSError:
                    ep.counts.setdefault("meas_tx_error", 0)
                    ep.counts["meas_tx_error"] += 1
            ak_now = int(now - ep.last_ctrl_wall <= self.ak_window_s)
            # the moment a loss has lasted the SDN app's DR hold, the turbine says so at once (the
            # app confirms DR on the turbine's own report, not on a guess from missing AKs)
            loss_due = (self.report_loss_after_s is not None and not ep.loss_reported
                        and now - ep.last_ctrl_wall >= self.report_loss_after_s)
            if send_ak or ak_now != ep.last_ak_sent or loss_due:  # periodic, on every change, at the hold
                ep.loss_reported = ep.loss_reported or loss_due
                self._send_ak(ep, ak_now, now, sec, nsec)

    def _send_ak(self, ep: Endpoint, ak: int, now: float, sec: int, nsec: int) -> None:
        ep.ak_seq += 1
        ep.ak_ones += ak
        ep.last_ak_sent = ak
        age_ms = min((now - ep.last_ctrl_wall) * 1e3, 1e6)
        values = {"wt": ep.wid, "seq": ep.ak_seq, "ak": ak, "ctrl_rx": ep.counts["ctrl_rx"], "ctrl_age_ms": age_ms}
        hdr = wire.Header(ep.ak_seq, sec, nsec) if self.header else None
        try:
            ep.sock.sendto(wire.encode(wire.MsgType.AK, values, header=hdr), (self.vip, wire.PORT_CONTROLLER))
            ep.counts["ak_tx"] += 1
        except OSError:
            pass

    # ------------------------------------------------------------------ loop
    def run(self) -> None:
        clock = self.clock
        t0 = float(self.cfg.t0_wall or clock.now())
        self.live.t0 = t0
        cpu_at_start = time.process_time()
        status_every = max(1, int(STATUS_EVERY_S / self.step_s))
        end = self.n_steps if self.n_steps is not None else float("inf")
        while self.k < end and not self.stop_requested:
            scheduled = t0 + self.k * self.step_s  # every time here is the run's clock (simulated seconds)
            now = clock.now()
            if now < scheduled:
                now = clock.sleep_until(scheduled)
            lateness = now - scheduled
            if lateness > self.step_s:
                self.late_steps += 1
                if lateness > 0.01 and len(self.stalls) < 100 and (not self.stalls or self.stalls[-1][2] < self.k - 1):
                    self.stalls.append([round(self.k * self.step_s, 4), round(lateness * 1e3, 2), self.k])
                elif self.stalls and self.stalls[-1][2] == self.k - 1:  # the same stall, still catching up
                    self.stalls[-1][1] = max(self.stalls[-1][1], round(lateness * 1e3, 2))
                    self.stalls[-1][2] = self.k
            self.max_lateness_s = max(self.max_lateness_s, lateness)
            self._drain(now)
            self.model.step()
            self.k += 1
            self._send(now)
            self.recorder.maybe_record(self.k, self.model)
            if self.k % status_every == 0:
                self.live.check_losses(self.endpoints, now)
                self.live.write_status(self, now)
        self.live.write_status(self, clock.now())
        self.cpu_s = time.process_time() - cpu_at_start  # from t = 0: what the paced loop cost

    def summary(self) -> dict:
        """What plant_stats.json holds (:func:`plant.service_summary.summarise`)."""
        return summarise(self)

    def close(self) -> None:
        self.recorder.close()
        self.live.close()
        for ep in self.endpoints:
            ep.sock.close()
        self.poller.close()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m plant.service", description=__doc__)
    parser.add_argument("--config", required=True)
    args = parser.parse_args(argv)
    try:
        cfg = load_config(PlantConfig, args.config)
    except ConfigError as exc:
        print(f"plant: {exc}", file=sys.stderr)
        return 2
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


if __name__ == "__main__":
    sys.exit(main())
