"""The SDC service's decisions, as pure code: datagrams and ``now`` in; datagrams to send, events
and counters out.

Nothing here touches a socket, waits, starts a thread or reads a clock: :meth:`SdcCore.handle`
takes the datagrams one wake-up of the service read (with when each was read) and the time to
stamp its answers with, and returns what to send. The process around it -- socket, the wait and
the gathering of one sample (:mod:`sdc_unit.gather`), the heartbeat timer, signals, the stats file
-- is :mod:`sdc_unit.service`, a thin shim (as :mod:`sdn_app.logic` under :mod:`sdn_app.app`).

One SDC serves every turbine the SDN application assigns to it. Commands (``REQUEST``, only from
the SDN app's address) start and stop a turbine's controller instance, set its parameters or make
a backup take over, each answered by a ``REPLY``; every usable ``MEAS`` advances its turbine's
controller by one step and is answered by one ``CTRL`` to the sender, its IP and UDP port (a
GTNET-SKT card serves several turbines from one IP, one port each; the switches that mirror a MEAS
to a backup or redirect it after a take-over rewrite only its destination). The datagrams are
handled in the order they were read: each MEAS is admitted (or dropped and counted) when it is
reached, the admitted ones are stepped together (:func:`sdc_unit.round.answer`: one compiled call
on the Tustin engine, whatever their number) before the next command and at the end. One admission
path whatever the batch size (:meth:`SdcCore._admit`).

Backup role (``role: backup``): measurements mirrored to it for turbines it does not serve are
followed but never answered. ``standby: track`` advances a full controller instance on every
mirrored sample (state identical to the primary's in exact arithmetic; doubles the SDC CPU);
``standby: latest`` (default) keeps the sequence position and initialises the instance at take-over
from the turbine's present operating point (bumpless by construction: the first output equals the
converter voltage the turbine applies). On ``TAKEOVER`` the instance starts answering.

What is let through is decided by :mod:`sdc_unit.admission` (unknown or unserved turbine,
out-of-range values, stale or inconsistent ``seq``/``t_sim``, commands not from the SDN app); every
datagram it drops is counted by reason (``rejected``, wire-level reasons from
:class:`sdvisc.wire.DecodeStats` included) and an unexpected exception while handling one is
counted (``internal``) and reported once in :attr:`Output.log`, never fatal. Sequence-number policy
(per turbine, on ``MEAS.seq``):

* ``seq`` ≤ the last one used → duplicate or out of order: dropped, counted (``meas_stale``);
  an older sample is never applied after a newer one. A jump that ``t_sim`` does not confirm is
  dropped (``inconsistent``) unless the next datagram confirms it (a restarted stream).
* ``seq`` > last + 1 → the gap is counted as lost (``meas_lost``); the controller takes one step
  with the sample that arrived (it runs on received samples; a lost sample is not invented).
* several samples of one turbine in one call (they queued while the process was busy) → each is
  used, in order, one step and one ``CTRL`` each.
* a malformed packet or one with NaN/Inf is dropped and counted (``rx_wire``); it never reaches a
  controller and no ``CTRL`` is sent for it.
"""

from __future__ import annotations

import math
import traceback
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from sdc_unit import admission
from sdc_unit.admission import SeqGate
from sdc_unit.bank import ControllerBank
from sdc_unit.round import answer
from sdvisc import wire
from sdvisc.config import SdcConfig
from sdvisc.stats import delay_summary
from sdvisc.vocabulary import MEAS_FIELDS, REQUEST_PARAM_WORDS, params_from_mask

MAX_RESUMED = 10_000
"""Losses of MEAS recorded per turbine (``meas_resumed``: the first MEAS after each, by its send time)."""
MAX_DELAYS = 200_000
"""MEAS one-way delays recorded per turbine."""
STREAMING_STEPS = 4
"""A turbine whose last measurement (admitted, or tracked by a backup) was read within this many
sampling periods counts as streaming: its MEAS is expected in every sample (:meth:`SdcCore.streaming`)."""


@dataclass
class Instance:
    """Per-turbine service state (the controller state lives in the bank, the CTRL numbering in
    :attr:`SdcCore.ctrl_seq`)."""

    name: str
    wid: int
    slot: int
    active: bool = False
    gate: SeqGate | None = None
    counts: dict = field(default_factory=lambda: {"meas_rx": 0, "ctrl_tx": 0, "meas_lost": 0, "meas_stale": 0,
                                                  "meas_inactive": 0, "meas_tracked": 0,
                                                  "ctrl_invalid": 0, "meas_rejected": 0})
    first_meas_rx_t: float | None = None
    last_meas_at: float = float("-inf")  # when its last usable MEAS was read (sdc_unit.gather)
    meas_delays_ms: list = field(default_factory=list)
    meas_resumed: list = field(default_factory=list)  # [send time, MEAS lost before it]: where a loss ended


class Output:
    """What one :meth:`SdcCore.handle` hands back: ``sends``, in order, as (datagram, address, the
    instance it answers or None for a REPLY); the ``events`` it recorded; ``log``: text for stderr
    (an unexpected error's traceback, once per place)."""

    __slots__ = ("sends", "events", "log")

    def __init__(self) -> None:
        self.sends: list[tuple[bytes, tuple, Instance | None]] = []
        self.events: list[dict] = []
        self.log: list[str] = []


class _Admitted:
    """The MEAS admitted since the last stepping, in order."""

    __slots__ = ("insts", "slots", "datagrams", "values", "addrs")

    def __init__(self) -> None:
        self.insts: list[Instance] = []
        self.slots: list[int] = []
        self.datagrams: list[bytes] = []
        self.values: list[tuple] = []
        self.addrs: list[tuple] = []


class SdcCore:
    """The SDC's state machine (see the module docstring)."""

    def __init__(self, cfg: SdcConfig) -> None:
        self.sdc_id = cfg.sdc_id
        self.step_s = cfg.step_s
        self.role = cfg.role
        self.backup = cfg.role == "backup"
        self.standby = cfg.standby
        self.header = cfg.header
        self.controller = (cfg.controller_vip, wire.PORT_CONTROLLER)
        self.instances: dict[int, Instance] = {}
        self.bank = ControllerBank(capacity=cfg.capacity + 1, step_s=cfg.step_s, method=cfg.method, dtype=cfg.dtype,
                                   law=cfg.law)
        self.ctrl_seq = np.zeros(self.bank.capacity, dtype=np.int64)
        """The last CTRL ``seq`` of each slot (advanced by the stepping, :func:`sdc_unit.round.answer`)."""
        self.rx_stats = wire.DecodeStats()
        meas_struct = wire.packer(wire.MsgType.MEAS, header=self.header)
        self._meas_words = meas_struct.unpack
        self._meas_size = meas_struct.size  # a MEAS: its length and its type word's place and bytes
        self._type_at = (wire.HEADER_WORDS if self.header else 0) * wire.WORD_BYTES
        self._meas_type = int(wire.MsgType.MEAS).to_bytes(wire.WORD_BYTES, "big", signed=True)
        self._wt_at = (wire.HEADER_WORDS if self.header else 0) + 1  # MEAS word of wt (seq, t_sim, values follow)
        self.hb_seq = 0
        self.unexpected_rx = 0
        self.rejected: Counter = Counter()  # by reason, see sdc_unit.admission (wire reasons: rx_stats)
        self.internal_logged: set[str] = set()
        self.events: list[dict] = []

    # ------------------------------------------------------------------ entry points
    def handle(self, datagrams: list[tuple[bytes, tuple]], now: float,
               read_at: list[float] | None = None) -> Output:
        """Handle received (datagram, sender) pairs in order: commands carried out, measurements
        admitted and answered. ``now``: the CTRL headers' stamp (and every datagram's read time
        unless ``read_at`` gives each its own: a command's REPLY and event, a MEAS's one-way delay
        end there). Nothing here raises on a bad datagram."""
        out = Output()
        first_event = len(self.events)
        admitted = _Admitted()
        size, at, meas_type = self._meas_size, self._type_at, self._meas_type
        for k, (data, addr) in enumerate(datagrams):
            read_t = now if read_at is None else read_at[k]
            if len(data) == size and data[at:at + wire.WORD_BYTES] == meas_type:  # is_meas, inline
                try:
                    self._admit(data, addr, read_t, admitted)
                except Exception as exc:  # noqa: BLE001 - one datagram never stops the service
                    self._internal_error("measurement", exc, out)
                continue
            if admitted.slots:  # what was read before a command is answered before it
                self._answer(admitted, now, out)
                admitted = _Admitted()
            msg = self.rx_stats.decode(data, header=self.header)
            if msg is None:
                continue  # counted by reason in rx_stats
            try:
                if msg.type == wire.MsgType.REQUEST:
                    self._on_request(msg, addr[0], read_t, out)
                else:
                    self.unexpected_rx += 1
                    self._reject("unexpected_type")
            except Exception as exc:  # noqa: BLE001 - one datagram never stops the service
                self._internal_error("request", exc, out)
        if admitted.slots:
            self._answer(admitted, now, out)
        out.events = self.events[first_event:]
        return out

    def is_meas(self, data: bytes) -> bool:
        """``data`` looks like a MEAS (length and type word; what :mod:`sdc_unit.gather` counts)."""
        at = self._type_at
        return len(data) == self._meas_size and data[at:at + wire.WORD_BYTES] == self._meas_type

    def streaming(self, now: float) -> int:
        """Turbines whose stream is flowing at ``now`` (a usable MEAS read within :data:`STREAMING_STEPS`
        samples): the measurements that make one sample complete (one that has gone quiet, e.g.
        behind a failed link, must not hold the others' answers back every sample)."""
        recent = now - STREAMING_STEPS * self.step_s
        return sum(1 for i in self.instances.values() if i.last_meas_at >= recent)

    def heartbeat(self, now: float) -> tuple[bytes, tuple]:
        """The next HEARTBEAT to the SDN app, stamped ``now``, and its address."""
        self.hb_seq += 1
        # (called from the service's heartbeat thread: the main loop may add an instance meanwhile;
        # list() copies at once)
        values = {"sdc_id": self.sdc_id, "seq": self.hb_seq,
                  "n_instances": sum(i.active for i in list(self.instances.values())), "t_wall": now % 1e4}
        return wire.encode(wire.MsgType.HEARTBEAT, values, header=self._header(self.hb_seq, now)), self.controller

    def send_failed(self, owner: Instance | None) -> None:
        """The shim could not send an answer of :attr:`Output.sends` (``owner`` as there)."""
        if owner is None:
            self.rejected["reply_tx_error"] += 1
        else:
            owner.counts["ctrl_tx"] -= 1
            owner.counts["ctrl_tx_error"] = owner.counts.get("ctrl_tx_error", 0) + 1

    def summary(self, shim: dict | None = None, delays: bool = True) -> dict:
        """The stats file's content; ``shim``: the service's own counters (after ``heartbeats_tx``);
        without ``delays`` no delay percentiles (their cost grows with the run: the snapshots while
        the SDC serves)."""
        wire_counts = self.rx_stats.as_dict()
        return {
            "sdc_id": self.sdc_id,
            "role": self.role,
            "rx_wire": wire_counts,
            "heartbeats_tx": self.hb_seq,
            **(shim or {}),
            "unexpected_rx": self.unexpected_rx,
            "rejected": {**{k: v for k, v in wire_counts.items() if k not in ("ok", "rejected") and v},
                         **self.rejected},
            "events": self.events,
            "turbines": {i.name: {**i.counts, "first_meas_rx_t": i.first_meas_rx_t,
                                  **({"meas_one_way_ms": delay_summary(i.meas_delays_ms)} if delays else {}),
                                  "meas_resumed": i.meas_resumed}
                         for i in self.instances.values()},
        }

    # ------------------------------------------------------------------ bookkeeping
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

    def _internal_error(self, where: str, exc: BaseException, out: Output) -> None:
        """An unexpected exception while handling received data: counted, reported once per place,
        and the service goes on."""
        self.rejected["internal"] += 1
        if where not in self.internal_logged:
            self.internal_logged.add(where)
            out.log.append("".join(traceback.format_exception(exc))
                           + f"sdc{self.sdc_id}: unexpected error in {where}; dropped and counted, serving on")

    def _header(self, seq: int, now: float) -> wire.Header | None:
        return wire.Header.at(seq, now) if self.header else None

    # ------------------------------------------------------------------ commands
    def _on_request(self, msg: wire.Message, src_ip: str, now: float, out: Output) -> None:
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
            self._reply(msg, status, wid, cmd, now, out)
            return
        if cmd in (wire.Command.START_INSTANCE, wire.Command.SET_PARAMS) and admission.bad_params(params):
            self._reject("bad_params")
            self.events.append({"t_wall": now, "type": "sdc_command", "cmd": wire.Command(cmd).name,
                                "wt": inst.name, "status": "REFUSED", "bad_params": admission.bad_params(params)})
            self._reply(msg, wire.Status.REFUSED, wid, cmd, now, out)
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
        self._reply(msg, status, wid, cmd, now, out)

    def _reply(self, msg: wire.Message, status: wire.Status, wid: int, cmd: int, now: float, out: Output) -> None:
        reply = {"req_id": msg["req_id"], "status": int(status), "wt": wid, "cmd": cmd, "detail": 0}
        header = self._header(msg["req_id"] & wire.UINT32_MAX, now)
        out.sends.append((wire.encode(wire.MsgType.REPLY, reply, header=header), self.controller, None))

    # ------------------------------------------------------------------ measurements
    def _admit(self, data: bytes, addr: tuple, read_t: float, admitted: _Admitted) -> None:
        """One MEAS datagram (right length and type word): the wire's value checks, then
        :mod:`sdc_unit.admission` in its order; a usable one joins ``admitted``, anything else is
        counted by reason (a backup's mirrored sample is followed)."""
        words = self._meas_words(data)
        at = self._wt_at
        wid, seq, t_sim = words[at:at + 3]
        values = words[at + 3:]
        if not math.isfinite(t_sim + sum(values)):  # float32 values: the sum is finite iff each is
            self.rx_stats.nonfinite += 1
            return
        self.rx_stats.ok += 1
        inst = self.instances.get(wid)  # (an instance exists only for a turbine id)
        if inst is None:
            if not admission.turbine_ok(wid):
                self._reject("unknown_turbine")
                return
            inst = self._instance(wid, create=self.backup)
            if inst is None:
                self._reject("unserved")
                return
        if admission.values_out_of_range(t_sim, values):
            self._reject("out_of_range", inst, "meas_rejected")
            return
        previous = inst.gate.last_seq
        verdict = inst.gate.admit(seq, t_sim)
        if verdict is not None:
            self._reject(verdict, inst, "meas_stale" if verdict == "stale" else "meas_rejected")
            return
        if not inst.active:
            if self.backup:  # warm standby on mirrored measurements: follow, never answer
                inst.counts["meas_tracked"] += 1
                inst.last_meas_at = read_t
                if self.standby == "track":
                    self.bank.track(np.array([inst.slot]), {k: np.array([v]) for k, v in zip(MEAS_FIELDS, values)})
            else:
                self._reject("inactive", inst, "meas_inactive")
            return
        self._count_usable(inst, previous, seq, t_sim, words[1] + words[2] * 1e-9 if self.header else None, read_t)
        admitted.insts.append(inst)
        admitted.slots.append(inst.slot)
        admitted.datagrams.append(data)
        admitted.values.append(values)
        admitted.addrs.append(addr)

    @staticmethod
    def _count_usable(inst: Instance, previous: int, seq: int, t_sim: float, sent: float | None,
                      read_t: float) -> None:
        """The bookkeeping of a MEAS that will be answered: samples lost before it (and where the
        stream resumed), its one-way delay (``sent``: its header's time, None without header)."""
        if previous >= 0 and seq > previous + 1:
            inst.counts["meas_lost"] += seq - previous - 1
            if sent is not None and len(inst.meas_resumed) < MAX_RESUMED:  # when the path delivered again
                inst.meas_resumed.append([round(sent, 6), seq - previous - 1])
        if sent is not None and len(inst.meas_delays_ms) < MAX_DELAYS:
            inst.meas_delays_ms.append((read_t - sent) * 1e3)
        inst.counts["meas_rx"] += 1
        inst.last_meas_at = read_t
        if inst.first_meas_rx_t is None:
            inst.first_meas_rx_t = t_sim

    def _answer(self, admitted: _Admitted, now: float, out: Output) -> None:
        """Step the admitted measurements (:func:`sdc_unit.round.answer`) and hand out one CTRL for
        each that gave a usable, encodable output (the others are counted ``ctrl_invalid``)."""
        try:
            answers = answer(self.bank, admitted.slots, admitted.datagrams, admitted.values, self.ctrl_seq,
                             self.backup, self.header, now)
        except Exception as exc:  # noqa: BLE001 - a bad round never stops the service
            self._internal_error("round", exc, out)
            return
        sends = out.sends
        for inst, addr, data in zip(admitted.insts, admitted.addrs, answers):
            if data is None:
                inst.counts["ctrl_invalid"] += 1
                continue
            inst.counts["ctrl_tx"] += 1
            sends.append((data, addr, inst))  # to the MEAS's source, ip and port (one card, several turbines)
