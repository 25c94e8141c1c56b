"""How the SDC service takes datagrams in: read everything waiting, gather one sample's measurements
(:mod:`sdc_unit.gather`), carry out commands, admit measurements (:mod:`sdc_unit.admission`) and
count by reason whatever is dropped. A mixin of :class:`sdc_unit.service.SdcService` (it uses the
service's socket, instances, counters and clock); nothing here raises on a bad datagram."""

from __future__ import annotations

import math

import numpy as np

from sdc_unit import admission
from sdc_unit.gather import gather
from sdvisc import wire
from sdvisc.vocabulary import MEAS_FIELDS
from sdvisc.wire_batch import decode_batch, float_rows, is_type

MAX_RESUMED = 10_000
"""Losses of MEAS recorded per turbine (``meas_resumed``: the first MEAS after each, by its send time)."""
ONE_BY_ONE_MAX = 24
"""Up to this many datagrams read at once, each MEAS is answered on its own
(:meth:`MeasurementIntake._answer_at_once`); more go through the vectorised batch path. Measured
(``benchmarks/sdc_round_cost.py --modes batch --gap-ms 0.67``, a round on cold caches): one by one
is cheaper up to ~24 MEAS per wake-up (16: ~165 against ~278 µs), equal at 32, dearer at 50."""
STREAMING_STEPS = 4
"""A turbine whose last measurement (admitted, or tracked by a backup) was read within this many
sampling periods counts as streaming: its MEAS is expected in every sample."""


class MeasurementIntake:
    """Reading, gathering and admission; see the module docstring."""

    def _read_waiting(self) -> list[tuple[bytes, tuple]]:
        """Every datagram waiting on the socket."""
        datagrams: list[tuple[bytes, tuple]] = []
        while True:
            try:
                datagrams.append(self.sock.recvfrom(2048))
            except BlockingIOError:
                break
            except OSError:  # e.g. an ICMP error queued on the socket: nothing to read, go on
                self.rejected["socket_error"] += 1
                break
        return datagrams

    def _drain(self, now: float, poller=None) -> dict[int, list[tuple[int, tuple]]]:
        """Read every waiting datagram, wait (up to the gather window) for the rest of the sample's
        measurements (:func:`sdc_unit.gather.gather`), and hand them to :meth:`receive`."""
        first = self._read_waiting()
        if poller is None or self.gather_wall_s <= 0 or not first:
            return self.receive(first, now)

        def read_more(timeout_s: float) -> list[tuple[bytes, tuple]]:
            return self._read_waiting() if poller.poll(timeout_s) else []

        # a complete sample: one MEAS from each turbine whose stream is flowing (one that has gone
        # quiet, e.g. behind a failed link, must not hold the others' answers back every sample)
        recent = now - STREAMING_STEPS * self.step_s
        expected = sum(1 for i in self.instances.values() if i.last_meas_at >= recent)
        datagrams, read_at, complete = gather(first, now, read_more, self._is_meas, expected, self.gather_wall_s,
                                    now=self.clock.now)
        self.gathered += len(datagrams) - len(first)
        self.gather_incomplete += not complete
        return self.receive(datagrams, now, read_at=read_at)

    def _is_meas(self, data: bytes) -> bool:
        return is_type(data, wire.MsgType.MEAS, self.header)

    def receive(self, datagrams: list[tuple[bytes, tuple]], now: float,
                read_at: list[float] | None = None) -> dict[int, list[tuple[int, tuple]]]:
        """Sort received (datagram, sender) pairs: commands are carried out at once, measurements
        admitted (:mod:`sdc_unit.admission`); returns, per turbine and in order, the usable ones as
        (row of ``self.rx_records``, sender address). MEAS datagrams are decoded together
        (:func:`sdvisc.wire_batch.decode_batch`). Whatever cannot be used is counted by reason in
        ``self.rejected`` and never reaches a controller; nothing here raises. ``read_at``: when each
        datagram was read (its MEAS one-way delay ends there), else ``now``."""
        meas_data: list[bytes] = []
        meas_addr: list[tuple] = []
        meas_read: list[float] = []
        one_by_one = self.bank.one_datagram and len(datagrams) <= ONE_BY_ONE_MAX
        for k, (data, addr) in enumerate(datagrams):
            if is_type(data, wire.MsgType.MEAS, self.header):
                if one_by_one:
                    try:
                        if self._answer_at_once(data, addr, read_at[k] if read_at is not None else now, now):
                            continue
                    except Exception as exc:  # noqa: BLE001 - one datagram never stops the service
                        self._internal_error("measurement", exc)
                        continue
                    one_by_one = False  # the rest of the batch after it, in order
                meas_data.append(data)
                meas_addr.append(addr)
                meas_read.append(read_at[k] if read_at is not None else now)
                continue
            msg = self.rx_stats.decode(data, header=self.header)
            if msg is None:
                continue  # counted by reason in rx_stats
            try:
                if msg.type == wire.MsgType.REQUEST:
                    self._on_request(msg, addr[0], now)
                else:
                    self.unexpected_rx += 1
                    self._reject("unexpected_type")
            except Exception as exc:  # noqa: BLE001 - one datagram never stops the service
                self._internal_error("request", exc)
        if not meas_data:
            return {}
        try:
            return self._admit_meas(meas_data, meas_addr, meas_read, now)
        except Exception as exc:  # noqa: BLE001 - one datagram never stops the service
            self._internal_error("measurements", exc)
            return {}

    def _admit_meas(self, meas_data: list[bytes], meas_addr: list[tuple], meas_read: list[float],
                    now: float) -> dict:
        batch: dict[int, list[tuple[int, tuple]]] = {}
        rec, index = decode_batch(meas_data, wire.MsgType.MEAS, header=self.header, stats=self.rx_stats)
        self.rx_records = rec
        # the header's send time and the admission's words of every row, as Python values, in one call
        words = rec[list(admission.ADMIT_WORDS if self.header else admission.ADMIT_WORDS[2:])].tolist()
        self.rx_rows = float_rows(rec, admission.CHECKED_ROWS)  # t_sim, then the MEAS_FIELDS
        out_of_range = admission.out_of_range_flags(self.rx_rows)
        sources = index.tolist()
        for j, row in enumerate(words):
            wid, seq, t_sim = row[-3:]
            if not admission.turbine_ok(wid):
                self._reject("unknown_turbine")
                continue
            inst = self._instance(wid, create=self.role == "backup")
            if inst is None:
                self._reject("unserved")
                continue
            if out_of_range[j]:
                self._reject("out_of_range", inst, "meas_rejected")
                continue
            previous = inst.gate.last_seq
            if not self._gate(inst, seq, t_sim):
                continue
            if not inst.active:
                if self.role == "backup":  # warm standby on mirrored measurements: follow, never answer
                    inst.counts["meas_tracked"] += 1
                    inst.last_meas_at = meas_read[sources[j]]
                    if self.standby == "track":
                        self.bank.track(np.array([inst.slot]),
                                        {k: rec[k][j:j + 1].astype(float) for k in MEAS_FIELDS})
                else:
                    self._reject("inactive", inst, "meas_inactive")
                continue
            self._count_usable(inst, previous, seq, t_sim, row[0] + row[1] * 1e-9 if self.header else None,
                               meas_read[sources[j]])
            batch.setdefault(wid, []).append((j, meas_addr[sources[j]]))
        return batch

    def _gate(self, inst, seq: int, t_sim: float) -> bool:
        """The turbine's sequence gate (:class:`sdc_unit.admission.SeqGate`); a drop is counted."""
        verdict = inst.gate.admit(seq, t_sim)
        if verdict is not None:
            self._reject(verdict, inst, "meas_stale" if verdict == "stale" else "meas_rejected")
        return verdict is None

    @staticmethod
    def _count_usable(inst, previous: int, seq: int, t_sim: float, sent: float | None, read_t: float) -> None:
        """The bookkeeping of a MEAS that will be answered: samples lost before it (and where the
        stream resumed), its one-way delay (``sent``: its header's time, None without header)."""
        if previous >= 0 and seq > previous + 1:
            inst.counts["meas_lost"] += seq - previous - 1
            if sent is not None and len(inst.meas_resumed) < MAX_RESUMED:  # when the path delivered again
                inst.meas_resumed.append([round(sent, 6), seq - previous - 1])
        if sent is not None and len(inst.meas_delays_ms) < 200_000:
            inst.meas_delays_ms.append((read_t - sent) * 1e3)
        inst.counts["meas_rx"] += 1
        inst.last_meas_at = read_t
        if inst.first_meas_rx_t is None:
            inst.first_meas_rx_t = t_sim

    def _answer_at_once(self, data: bytes, addr: tuple, read_t: float, now: float) -> bool:
        """A MEAS (right length and type) of a turbine whose controller is running, admitted and
        answered on its own (:meth:`sdc_unit.bank.ControllerBank.meas_to_ctrl`: one compiled call
        steps it and writes the CTRL) with the checks, counts and order of the batch path. False,
        with nothing changed, where it needs the batch path: an unknown, inactive or not yet
        initialised turbine, a non-finite or out-of-range value."""
        words = self._meas_words(data)
        wid, seq, t_sim = words[self._wt_at:self._wt_at + 3]
        inst = self.instances.get(wid)
        if inst is None or not inst.active or not self.bank.answers_one(inst.slot):
            return False
        values = words[self._wt_at + 3:]
        if not math.isfinite(t_sim + sum(values)) or admission.values_out_of_range(t_sim, values):
            return False
        self.rx_stats.ok += 1
        previous = inst.gate.last_seq
        if self._gate(inst, seq, t_sim):
            self._count_usable(inst, previous, seq, t_sim, words[1] + words[2] * 1e-9 if self.header else None, read_t)
            self._answer_one(inst, data, seq, addr, now)
        return True
