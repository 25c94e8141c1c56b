"""The SDC unit as a network service: ``python -m sdc_unit.service --config FILE``, run inside an
SDC Mininet host.

One process serves every turbine the SDN application assigns to it. It listens on
``wire.PORT_SDC`` for ``REQUEST`` commands (start/stop an instance, set parameters, take over) and
for ``MEAS`` packets; each received measurement advances that turbine's controller by one step and
is answered by one ``CTRL`` packet to the sender. Heartbeats go to the SDN application.

Backup role (``role: backup``): measurements mirrored to it for turbines it does not serve are
followed but never answered. ``standby: track`` advances a full controller instance on every
mirrored sample (state identical to the primary's in exact arithmetic; doubles the SDC CPU);
``standby: latest`` (default) keeps the sequence position and initialises the instance at take-over
from the turbine's present operating point (bumpless by construction: the first output equals the
converter voltage the turbine applies). On ``TAKEOVER`` the instance starts answering.

What is let through is decided by :mod:`sdc_unit.admission` (unknown or unserved turbine,
out-of-range values, stale or inconsistent ``seq``/``t_sim``, commands not from the SDN app); every
datagram it drops is counted by reason (``rejected`` in the stats file, wire-level reasons from
:class:`sdvisc.wire.DecodeStats` included) and an unexpected exception while handling one is
counted (``internal``) and logged, never fatal. Sequence-number policy (per turbine, on ``MEAS.seq``):

* ``seq`` ≤ the last one used → duplicate or out of order: dropped, counted (``meas_stale``);
  an older sample is never applied after a newer one. A jump that ``t_sim`` does not confirm is
  dropped (``inconsistent``) unless the next datagram confirms it (a restarted stream).
* ``seq`` > last + 1 → the gap is counted as lost (``meas_lost``); the controller takes one step
  with the sample that arrived (it runs on received samples; a lost sample is not invented).
* several samples of one turbine waiting in one receive batch (they queued while the process was
  busy) → each is used, in order, one step and one ``CTRL`` each; turbines are stepped together.
* a malformed packet or one with NaN/Inf is dropped and counted (``rx_rejected``); it never
  reaches a controller and no ``CTRL`` is sent for it.
"""

from __future__ import annotations

import argparse
import json
import os
import select
import signal
import socket
import sys
import threading
import time
import traceback
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sdc_unit import admission
from sdc_unit.admission import SeqGate
from sdc_unit.answer import NOT_STEPPED, UNENCODABLE, ctrl_bytes
from sdc_unit.bank import ControllerBank
from sdc_unit.intake import MeasurementIntake
from sdc_unit.round import FLAG_BACKUP, header_time, pack_ctrl, step_round
from sdvisc import wire
from sdvisc.config import ConfigError, SdcConfig, load_config
from sdvisc.jsonlines import write_json_atomic
from sdvisc.netns import raise_priority
from sdvisc.stats import delay_summary
from sdvisc.vocabulary import REQUEST_PARAM_WORDS, params_from_mask
from sdvisc.wire_batch import record_dtype

HEARTBEAT_S = 0.01
IDLE_WAIT_S = 0.5
"""Wall seconds the main loop waits for a datagram before it looks at ``until`` again (:meth:`SdcService.stop`
ends the wait at once). Nothing else in the loop is timed: the heartbeats have their own thread, so
an idle SDC wakes only for them (it woke every 5 ms before, ~12 µs of CPU per plant step)."""


@dataclass
class Instance:
    """Per-turbine service state (the controller state lives in the bank)."""

    name: str
    wid: int
    slot: int
    addr: tuple[str, int] | None = None
    active: bool = False
    gate: SeqGate | None = None
    ctrl_seq: int = 0
    counts: dict = field(default_factory=lambda: {"meas_rx": 0, "ctrl_tx": 0, "meas_lost": 0, "meas_stale": 0,
                                                  "meas_inactive": 0, "meas_tracked": 0,
                                                  "ctrl_invalid": 0, "meas_rejected": 0})
    first_meas_rx_t: float | None = None
    last_meas_at: float = float("-inf")  # run clock when its last usable MEAS was read (sdc_unit.gather)
    meas_delays_ms: list = field(default_factory=list)
    meas_resumed: list = field(default_factory=list)  # [send time, MEAS lost before it]: where a loss ended


class SdcService(MeasurementIntake):
    """See the module docstring."""

    def __init__(self, cfg: SdcConfig, sock: socket.socket | None = None) -> None:
        self.cfg = cfg
        self.clock = cfg.clock()
        self.sdc_id = cfg.sdc_id
        self.step_s = cfg.step_s
        self.role = cfg.role
        self.standby = cfg.standby
        self.header = cfg.header
        self.controller = (cfg.controller_vip, wire.PORT_CONTROLLER)
        self.sock = sock or self._open_socket(cfg.bind_ip)
        self.instances: dict[int, Instance] = {}
        self.bank = ControllerBank(capacity=cfg.capacity + 1, step_s=cfg.step_s, method=cfg.method, dtype=cfg.dtype)
        self.rx_stats = wire.DecodeStats()
        self._meas_words = wire.packer(wire.MsgType.MEAS, header=self.header).unpack  # the one-datagram path's
        self._wt_at = (wire.HEADER_WORDS if self.header else 0) + 1  # MEAS word of wt (seq, t_sim, values follow)
        self._ctrl_out = np.zeros(ctrl_bytes(self.header), dtype=np.uint8)
        self.rx_records = np.zeros(0, dtype=record_dtype(wire.MsgType.MEAS, self.header))
        self.rx_rows = np.zeros((len(admission.CHECKED_ROWS), 0))  # their checked values (float_rows)
        self.hb_seq = 0
        self.unexpected_rx = 0
        self.rejected: Counter = Counter()  # by reason, see sdc_unit.admission (wire reasons: rx_wire)
        self.internal_logged: set[str] = set()
        self.events: list[dict] = []
        self.gather_wall_s = self.clock.wall_s(cfg.gather_steps * cfg.step_s)
        self.gathered = 0  # datagrams read while waiting for the rest of a sample
        self.gather_incomplete = 0  # waits the window ended before every streaming turbine's MEAS came
        self.running = True
        self._wake_fd = -1  # run()'s eventfd while it runs, written by stop(): ends the idle wait

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

    def _instance(self, wid: int, *, create: bool) -> Instance | None:
        """The turbine's instance; a new one only with ``create`` and while a slot is free (the
        bank's last slot is the warm-up scratch slot)."""
        inst = self.instances.get(wid)
        if inst is None and create and len(self.instances) < self.bank.capacity - 1:
            inst = Instance(wire.turbine_name(wid), wid, slot=len(self.instances), gate=SeqGate(self.step_s))
            self.instances[wid] = inst
        return inst

    def _reject(self, reason: str, inst: Instance | None = None, key: str | None = None) -> None:
        self.rejected[reason] += 1
        if inst is not None and key is not None:
            inst.counts[key] += 1

    def _internal_error(self, where: str, exc: BaseException) -> None:
        """An unexpected exception while handling received data: counted, logged once per place,
        and the service goes on."""
        self.rejected["internal"] += 1
        if where not in self.internal_logged:
            self.internal_logged.add(where)
            traceback.print_exception(exc, file=sys.stderr)
            print(f"sdc{self.sdc_id}: unexpected error in {where}; dropped and counted, serving on", file=sys.stderr)

    def _header(self, seq: int, now: float) -> wire.Header | None:
        if not self.header:
            return None
        return wire.Header.at(seq, now)

    # ------------------------------------------------------------------ commands
    def _on_request(self, msg: wire.Message, src_ip: str, now: float) -> None:
        """A command from the SDN application (only from its address; anything else is counted)."""
        if src_ip != self.controller[0]:
            self._reject("not_controller")
            return
        cmd, wid = msg["cmd"], msg["wt"]
        if not admission.turbine_ok(wid):
            self._reject("unknown_turbine")
            return
        params = {k: msg[k] for k in REQUEST_PARAM_WORDS}
        starting = cmd in (wire.Command.START_INSTANCE, wire.Command.TAKEOVER)
        inst = self._instance(wid, create=starting)
        status = wire.Status.OK
        if inst is None:
            self._reject("unserved" if not starting else "capacity")
            status = wire.Status.REFUSED if not starting else wire.Status.BUSY
            self._answer(msg, status, wid, cmd, now)
            return
        if cmd in (wire.Command.START_INSTANCE, wire.Command.SET_PARAMS) and admission.bad_params(params):
            self._reject("bad_params")
            self.events.append({"t_wall": now, "type": "sdc_command", "cmd": wire.Command(cmd).name,
                                "wt": inst.name, "status": "REFUSED", "bad_params": admission.bad_params(params)})
            self._answer(msg, wire.Status.REFUSED, wid, cmd, now)
            return
        if cmd == wire.Command.START_INSTANCE:
            inst.active = True
            inst.gate.reset()
            self.bank.start(inst.slot, params)
        elif cmd == wire.Command.STOP_INSTANCE:
            inst.active = False
            self.bank.stop(inst.slot)
        elif cmd == wire.Command.SET_PARAMS:
            if inst.active:
                self.bank.set_params(inst.slot, params)
            else:
                status = wire.Status.REFUSED
        elif cmd == wire.Command.TAKEOVER:
            inst.active = True
            self.bank.take_over(inst.slot)
            inst.counts["takeover_warm"] = int(self.bank.initialised[inst.slot])
        else:
            status = wire.Status.BAD_REQUEST
        event = {"t_wall": now, "type": "sdc_command", "cmd": wire.Command(cmd).name, "wt": inst.name,
                 "status": status.name}
        if cmd == wire.Command.SET_PARAMS and status == wire.Status.OK:  # what was asked and what now steps
            event.update(params=params_from_mask(params), in_effect=self.bank.runtime_params(inst.slot),
                         pending=inst.slot in self.bank.pending_params)
        self.events.append(event)
        self._answer(msg, status, wid, cmd, now)

    def _answer(self, msg: wire.Message, status: wire.Status, wid: int, cmd: int, now: float) -> None:
        reply = {"req_id": msg["req_id"], "status": int(status), "wt": wid, "cmd": cmd, "detail": 0}
        try:
            self.sock.sendto(wire.encode(wire.MsgType.REPLY, reply, header=self._header(msg["req_id"] & wire.UINT32_MAX,
                                                                                          now)), self.controller)
        except OSError:
            self.rejected["reply_tx_error"] += 1

    def _serve(self, batch: dict[int, list[tuple[int, tuple]]], now: float) -> None:
        """One controller step per measurement, in sequence order; turbines stepped together."""
        depth = max((len(v) for v in batch.values()), default=0)
        for r in range(depth):
            try:
                self._serve_round({w: v[r] for w, v in batch.items() if len(v) > r}, now)
            except Exception as exc:  # noqa: BLE001 - a bad round never stops the service
                self._internal_error("round", exc)

    def _serve_round(self, newest: dict[int, tuple[int, tuple]], now: float) -> None:
        """Step the turbines of one round together (:func:`sdc_unit.round.step_round`) and answer
        each with one CTRL."""
        insts = [self.instances[w] for w in newest]
        rows = [newest[i.wid][0] for i in insts]
        slots = np.array([i.slot for i in insts], dtype=np.intp)
        rec, meas_rows = self.rx_records, self.rx_rows[1:]
        if rows != list(range(len(rec))):  # usually every row, in order
            rec, meas_rows = rec[rows], meas_rows[:, rows]
        valid, ctrl = step_round(self.bank, slots, rec, backup=self.role == "backup", meas_rows=meas_rows)
        oks = valid.tolist()
        for inst in (i for i, ok in zip(insts, oks) if not ok):
            inst.counts["ctrl_invalid"] += 1
        sent = [i for i, ok in zip(insts, oks) if ok]
        if not sent:
            return
        for inst in sent:
            inst.ctrl_seq += 1
        seqs = np.array([inst.ctrl_seq for inst in sent])
        for inst, data in zip(sent, pack_ctrl(ctrl, seqs, now if self.header else None)):
            if data is None:
                inst.counts["ctrl_invalid"] += 1
                continue
            try:
                self.sock.sendto(data, (newest[inst.wid][1][0], wire.PORT_TURBINE))
                inst.counts["ctrl_tx"] += 1
            except OSError:
                inst.counts["ctrl_tx_error"] = inst.counts.get("ctrl_tx_error", 0) + 1

    def _answer_one(self, inst: Instance, data: bytes, meas_seq: int, addr: tuple, now: float) -> None:
        """Step ``inst`` on one admitted MEAS datagram and send its CTRL (the one-datagram path of
        :meth:`receive`; counted as :meth:`_serve_round` counts)."""
        sec, nsec = header_time(self.clock.now() if self.gather_wall_s > 0 else now) if self.header else (0, 0)
        code = self.bank.meas_to_ctrl(inst.slot, data, self.header, self._ctrl_out, inst.wid, inst.ctrl_seq + 1,
                                      meas_seq, FLAG_BACKUP if self.role == "backup" else 0, sec, nsec)
        if code == NOT_STEPPED:
            inst.counts["ctrl_invalid"] += 1
            return
        inst.ctrl_seq += 1
        if code == UNENCODABLE:
            inst.counts["ctrl_invalid"] += 1
            return
        try:
            self.sock.sendto(self._ctrl_out, (addr[0], wire.PORT_TURBINE))
            inst.counts["ctrl_tx"] += 1
        except OSError:
            inst.counts["ctrl_tx_error"] = inst.counts.get("ctrl_tx_error", 0) + 1

    def _heartbeat(self, now: float) -> None:
        self.hb_seq += 1
        # (the heartbeat thread: the main loop may add an instance meanwhile; list() copies at once)
        values = {"sdc_id": self.sdc_id, "seq": self.hb_seq,
                  "n_instances": sum(i.active for i in list(self.instances.values())), "t_wall": now % 1e4}
        try:
            self.sock.sendto(wire.encode(wire.MsgType.HEARTBEAT, values, header=self._header(self.hb_seq, now)),
                             self.controller)
        except OSError:
            pass

    def _heartbeat_loop(self) -> None:
        """Heartbeats from their own thread: they say the process is alive even while the main loop
        works through a burst (a dead process stops them at once; a stuck loop shows in the AKs)."""
        while self.running:
            self._heartbeat(self.clock.now())
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
                now = self.clock.now()  # the run's one clock: stamps, delays and events in simulated seconds
                batch = self._drain(now, poller)
                self._serve(batch, self.clock.now() if self.gather_wall_s > 0 else now)
        finally:
            self.running = False
            beats.join(timeout=1.0)
            poller.close()
            waiter.close()
            fd, self._wake_fd = self._wake_fd, -1
            os.close(fd)

    def summary(self) -> dict:
        return {
            "sdc_id": self.sdc_id,
            "role": self.role,
            "rx_wire": self.rx_stats.as_dict(),
            "heartbeats_tx": self.hb_seq,
            "gather_window_wall_s": self.gather_wall_s,
            "gathered": self.gathered,
            "gather_incomplete": self.gather_incomplete,
            "unexpected_rx": self.unexpected_rx,
            "rejected": {**{k: v for k, v in self.rx_stats.as_dict().items() if k not in ("ok", "rejected") and v},
                         **self.rejected},
            "events": self.events,
            "turbines": {i.name: {**i.counts, "first_meas_rx_t": i.first_meas_rx_t,
                                  "meas_one_way_ms": delay_summary(i.meas_delays_ms),
                                  "meas_resumed": i.meas_resumed}
                         for i in self.instances.values()},
        }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sdc_unit.service", description=__doc__)
    parser.add_argument("--config", required=True)
    args = parser.parse_args(argv)
    try:
        cfg = load_config(SdcConfig, args.config)
    except ConfigError as exc:
        print(f"sdc: {exc}", file=sys.stderr)
        return 2
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
    try:
        service.run()
    finally:
        (out_dir / f"sdc{service.sdc_id}_stats.json").write_text(json.dumps(service.summary(), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
