"""The plant service's decisions, as pure code: datagrams, events and ``now`` in; datagrams, events
and counters out.

Nothing here opens a socket, polls, sleeps, starts a thread, reads a clock or writes a file: every
entry point takes ``now`` (the run clock's reading, s) and :meth:`PlantCore.step` returns the
datagrams to send. The shim in :mod:`plant.service` owns the sockets (one per turbine, in the
turbine host's namespace), the pacing, stdin, the recorder and the status files, and only
translates — as :mod:`sdn_app.app` does for :class:`sdn_app.logic.Controller`.

Per step the shim hands every datagram that arrived to :meth:`PlantCore.receive` (and every stdin
event to :meth:`PlantCore.apply_event`), then calls :meth:`PlantCore.step`: the newest accepted
``CTRL`` of each streaming turbine is applied to the model in one vectorised call (hold last value;
the model falls back after its ``remote_loss_fallback_s``), the model advances one step, and each
streaming turbine's ``MEAS`` is returned, followed by its ``AK`` (1 when a ``CTRL`` arrived within
``ak_window_s``) to the SDN application every ``ak_period_s``, at once whenever it changes, and
once when a loss has lasted ``report_loss_after_s``. Returned datagrams are counted as sent
(``meas_tx``, ``ak_tx``); the shim reports one the socket refused with
:meth:`PlantCore.send_failed`. Events (stream start/stop, scenario events, the control-packet
events of :mod:`plant.service.live`) go to the injected :class:`plant.service.live.LivePublisher` (without an
output directory it only collects them).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from plant.service import endpoint_rx
from plant.service.endpoint_tx import MeasPacker
from plant.service.live import LivePublisher
from plant.service.model import apply_set, farm_index
from sdvisc import wire
from sdvisc.vocabulary import MEAS_FIELDS

RTT_BINS = 8
CTRL_GAP_STEPS = 2.5  # a pause between control packets longer than this many steps is recorded (>= 2 missing)
MAX_CTRL_GAPS = 100_000  # per turbine (a long run on a loaded machine at k = 1)
MAX_STALLS = 100


@dataclass
class Endpoint:
    """One turbine's network endpoint and its packet counters (no socket: the shim holds it)."""

    name: str
    wid: int
    index: int
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
    awaiting_first_ctrl: bool = False  # streaming started, no control packet yet (plant.service.live)
    stream_started_wall: float = 0.0
    ctrl_lost_reported: bool = False
    live_delay: list = field(default_factory=lambda: [0.0, 0])  # sum (ms) and count since the last status


class Pacing:
    """The paced loop's lateness record (plant_stats.json): steps later than one step, the worst
    lateness, and each stall (> 10 ms late) as [t_sim at its start, worst lateness ms, last step]."""

    def __init__(self, step_s: float) -> None:
        self.step_s = step_s
        self.late_steps = 0
        self.stalls: list[list] = []
        self.max_lateness_s = 0.0

    def note(self, k: int, lateness: float) -> None:
        """Step ``k`` started ``lateness`` seconds after its scheduled time."""
        if lateness > self.step_s:
            self.late_steps += 1
            stalls = self.stalls
            if lateness > 0.01 and len(stalls) < MAX_STALLS and (not stalls or stalls[-1][2] < k - 1):
                stalls.append([round(k * self.step_s, 4), round(lateness * 1e3, 2), k])
            elif stalls and stalls[-1][2] == k - 1:  # the same stall, still catching up
                stalls[-1][1] = max(stalls[-1][1], round(lateness * 1e3, 2))
                stalls[-1][2] = k
        self.max_lateness_s = max(self.max_lateness_s, lateness)


class PlantCore:
    """The turbines' endpoints around the plant model; see the module docstring.

    ``cfg``: the service's :class:`sdvisc.config.PlantConfig` (read once here); ``model``: the
    plant model, a :class:`plant.backend.PlantBackend` (:func:`plant.service.model.build_model`), and
    ``indices`` its index of each of
    ``cfg.turbines``; ``live``: where events go (default: collected only, no files).
    """

    def __init__(self, cfg, model, indices, live: LivePublisher | None = None) -> None:
        self.step_s = cfg.step_s
        self.n_steps = int(round(cfg.duration_s / self.step_s)) if cfg.duration_s is not None else None  # None: until stopped
        self.header = cfg.header
        self.vip = cfg.controller_vip
        self.ak_addr = (self.vip, wire.PORT_CONTROLLER)
        self.ak_every = max(1, int(round(cfg.ak_period_s / self.step_s)))
        self.ak_window_s = cfg.ak_window_s
        self.report_loss_after_s = cfg.report_loss_after_s
        self.check_rx_source = cfg.check_rx_source  # see plant.service.endpoint_rx
        self.model = model
        self.endpoints = [Endpoint(t.name, t.wid, index) for t, index in zip(cfg.turbines, indices)]
        self.streaming: list[Endpoint] = []  # the endpoints streaming, in endpoint order (kept by _on_request)
        self.rx_stats = wire.DecodeStats()
        self.meas_packer = MeasPacker(self.header)
        self.k = 0
        self.live = live if live is not None else LivePublisher(None, [])
        self.events_applied: list[dict] = self.live.events
        given = {t.name: t.plant_index for t in cfg.turbines}
        self.batteries = {name: farm_index(name, model.n, given=given.get(name)) for name in cfg.batteries}
        self.soc_start = {name: float(model.tb.batt.soc[i]) for name, i in self.batteries.items()}
        self.stop_requested = False
        self._newest: dict[int, wire.Message] = {}  # model index -> the newest CTRL received since the last step

    # ------------------------------------------------------------------ receive
    def receive(self, ep: Endpoint, data: bytes, addr, now: float) -> None:
        """One datagram that arrived on ``ep``'s socket from ``addr`` (ip, port) at ``now``. Never
        raises: whatever is not accepted is counted (:mod:`plant.service.endpoint_rx`), and so is a
        datagram whose handling raised (``rx_reject_internal``)."""
        try:
            action, msg = endpoint_rx.receive(ep, data, addr, header=self.header, controller_ip=self.vip,
                                              stats=self.rx_stats, check_source=self.check_rx_source)
            if action == endpoint_rx.APPLY:
                self._on_ctrl(ep, msg, now)
                if ep.streaming:
                    self._newest[ep.index] = msg
            elif action == endpoint_rx.REQUEST:
                self._on_request(ep, msg, now)
        except Exception as error:  # noqa: BLE001 - counted and logged once
            endpoint_rx.count_internal(ep.counts, error)

    def socket_error(self, ep: Endpoint) -> None:
        """``ep``'s socket reported an error instead of a datagram (e.g. an ICMP error)."""
        ep.counts["rx_socket_error"] = ep.counts.get("rx_socket_error", 0) + 1

    def _on_ctrl(self, ep: Endpoint, msg: wire.Message, now: float) -> None:
        """Account for one CTRL that :func:`plant.service.endpoint_rx.receive` accepted (the newest so far)."""
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
        """Carry out a STREAM_START/STREAM_STOP that :func:`plant.service.endpoint_rx.receive` accepted."""
        ep.counts["requests_rx"] += 1
        cmd = msg["cmd"]
        t_sim = self.k * self.step_s
        if cmd == wire.Command.STREAM_START:
            self.model.set_mode(ep.index, "remote")  # first: a model that refuses (no converter of its own) raises
            if not ep.streaming:
                ep.awaiting_first_ctrl = True
                ep.stream_started_wall = now
            ep.streaming = True
            self.streaming = [e for e in self.endpoints if e.streaming]
            ep.sdc_addr = (wire.i32_to_ip(msg["sdc_ip"]), wire.PORT_SDC)
            self.live.event({"t": t_sim, "type": "stream_start", "wt": ep.name, "sdc": ep.sdc_addr[0]})
        elif cmd == wire.Command.STREAM_STOP:
            ep.streaming = False
            self.streaming = [e for e in self.endpoints if e.streaming]
            self.model.set_mode(ep.index, "grid_following")
            self.live.event({"t": t_sim, "type": "stream_stop", "wt": ep.name})

    def apply_event(self, event: dict) -> None:
        """A scenario event (stdin's JSON lines): ``stop`` (sets :attr:`stop_requested`),
        ``load_step``, ``fault``, ``scr``, ``set``; anything else raises ValueError."""
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

    # ------------------------------------------------------------------ step
    def step(self, now: float) -> list[tuple[Endpoint, bytes, tuple[str, int]]]:
        """Apply the newest CTRL received per streaming turbine, advance the model one step, and
        return the datagrams due, in order — every MEAS, then the AKs due: (endpoint, datagram,
        destination address)."""
        newest = self._newest
        if newest:
            index = np.fromiter(newest, dtype=np.intp, count=len(newest))
            refs = np.array([[m["v_ref_d"], m["v_ref_q"], m["i_ref_d"], m["i_ref_q"]] for m in newest.values()],
                            dtype=np.float64).T.copy()  # one contiguous row per reference
            self._newest = {}
            self.model.apply_remote(index, refs[0], refs[1], refs[2], refs[3])
        self.model.step()
        self.k += 1
        return self._outgoing(now) if self.streaming else []

    def _outgoing(self, now: float) -> list[tuple[Endpoint, bytes, tuple[str, int]]]:
        out: list = []
        aks: list = []  # after every MEAS: a step that reports AKs does not hold up the last turbines' MEAS
        meas = self.model.measurements()
        columns = [meas[key] for key in MEAS_FIELDS]
        t_sim = self.k * self.step_s
        sec = int(now)
        nsec = int((now - sec) * 1e9)
        send_ak = self.k % self.ak_every == 0
        pack = self.meas_packer.pack
        ak_window_s, loss_after_s = self.ak_window_s, self.report_loss_after_s
        for ep in self.streaming:
            i = ep.index
            ep.meas_seq += 1
            data = pack(ep.wid, ep.meas_seq, t_sim, [float(column[i]) for column in columns], sec, nsec)
            counts = ep.counts
            if data is None:  # a value the wire cannot carry (the model diverged): counted, not sent
                counts["meas_unencodable"] = counts.get("meas_unencodable", 0) + 1
            else:
                out.append((ep, data, ep.sdc_addr))
                counts["meas_tx"] += 1  # taken back by send_failed
                if ep.first_meas_tx_t is None:
                    ep.first_meas_tx_t = t_sim
            ak_now = int(now - ep.last_ctrl_wall <= ak_window_s)
            # the moment a loss has lasted the SDN app's DR hold, the turbine says so at once (the
            # app confirms DR on the turbine's own report, not on a guess from missing AKs)
            loss_due = (loss_after_s is not None and not ep.loss_reported
                        and now - ep.last_ctrl_wall >= loss_after_s)
            if send_ak or ak_now != ep.last_ak_sent or loss_due:  # periodic, on every change, at the hold
                ep.loss_reported = ep.loss_reported or loss_due
                aks.append((ep, self._ak(ep, ak_now, now, sec, nsec), self.ak_addr))
        out.extend(aks)
        return out

    def _ak(self, ep: Endpoint, ak: int, now: float, sec: int, nsec: int) -> bytes:
        ep.ak_seq += 1
        ep.ak_ones += ak
        ep.last_ak_sent = ak
        age_ms = min((now - ep.last_ctrl_wall) * 1e3, 1e6)
        values = {"wt": ep.wid, "seq": ep.ak_seq, "ak": ak, "ctrl_rx": ep.counts["ctrl_rx"], "ctrl_age_ms": age_ms}
        hdr = wire.Header(ep.ak_seq, sec, nsec) if self.header else None
        data = wire.encode(wire.MsgType.AK, values, header=hdr)
        ep.counts["ak_tx"] += 1  # taken back by send_failed
        return data

    def send_failed(self, ep: Endpoint, addr) -> None:
        """The socket refused a datagram :meth:`step` returned for ``ep`` to ``addr``: a MEAS is
        counted as ``meas_tx_error`` instead of ``meas_tx``, an AK is not counted in ``ak_tx``."""
        counts = ep.counts
        if addr == self.ak_addr:
            counts["ak_tx"] -= 1
            return
        counts["meas_tx"] -= 1
        counts["meas_tx_error"] = counts.get("meas_tx_error", 0) + 1
        if not counts["meas_tx"]:  # that was the first: none sent yet
            ep.first_meas_tx_t = None
