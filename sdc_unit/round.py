"""Stepping and answering without a socket: admitted MEAS in, CTRL datagrams out.

No socket, no clock, no per-turbine bookkeeping: :class:`sdc_unit.core.SdcCore` admits the
datagrams before (:mod:`sdc_unit.admission`) and counts and hands out the answers after.
:func:`answer` is the one way the core steps: on the compiled Tustin engine one kernel call for the
whole batch (:meth:`sdc_unit.bank.ControllerBank.answer_datagrams`), on any other engine or method
:func:`answer_rows` -- rounds in which every turbine appears at most once, each stepped together
(:func:`step_round`: one vectorised call) and packed together (:func:`pack_ctrl`); the answers in
the order of the datagrams either way. ``benchmarks/sdc_throughput.py`` times the two round functions.
"""

from __future__ import annotations

import numpy as np

from sdvisc import wire
from sdvisc.vocabulary import CTRL_OUTPUTS, MEAS_FIELDS
from sdvisc.wire_batch import encode_batch, float_rows

from .answer import FLAG_BACKUP, FLAG_LIMITED, header_time
from .bank import ControllerBank

__all__ = ["FLAG_BACKUP", "FLAG_LIMITED", "answer", "answer_rows", "header_time", "pack_ctrl", "step_round"]


def answer(bank: ControllerBank, slots: list[int], datagrams: list[bytes], values: list[tuple], ctrl_seq: np.ndarray,
           backup: bool, header: bool, now: float) -> list[bytes | None]:
    """The CTRL datagram answering each admitted MEAS datagram (``slots[j]``'s controller advanced on
    ``datagrams[j]``, whose MEAS_FIELDS are ``values[j]``), in order, or None where there is none
    (not stepped: no ``seq`` used; not encodable: its ``seq`` used); ``ctrl_seq[slot]``, the last
    ``seq`` of each slot, advanced in place. Header stamped ``now`` when ``header``, flag bit 1 when
    ``backup``."""
    if bank.compiled_answers:
        return bank.answer_datagrams(slots, datagrams, values, ctrl_seq, backup, header, now)
    return answer_rows(bank, slots, datagrams, values, ctrl_seq, backup, header, now)


def answer_rows(bank: ControllerBank, slots: list[int], datagrams: list[bytes], values: list[tuple],
                ctrl_seq: np.ndarray, backup: bool, header: bool, now: float) -> list[bytes | None]:
    """:func:`answer` by numpy rounds (any method and engine; the compiled way's reference)."""
    answers: list[bytes | None] = [None] * len(slots)
    rest = list(range(len(slots)))
    meas_words = wire.packer(wire.MsgType.MEAS, header=header).unpack
    wt_at = (wire.HEADER_WORDS if header else 0) + 1
    while rest:
        rows: list[int] = []
        later: list[int] = []
        seen: set[int] = set()
        for j in rest:  # a turbine's next sample waits for the next round
            (later if slots[j] in seen else rows).append(j)
            seen.add(slots[j])
        words = [meas_words(datagrams[j])[wt_at:wt_at + 2] for j in rows]
        meas = {"wt": np.array([w[0] for w in words]), "seq": np.array([w[1] for w in words])}
        matrix = np.array([values[j] for j in rows], dtype=float).T
        valid, ctrl = step_round(bank, np.array([slots[j] for j in rows], dtype=np.intp), meas, backup, matrix)
        sent = [j for j, ok in zip(rows, valid.tolist()) if ok]
        for j in sent:
            ctrl_seq[slots[j]] += 1
        if sent:
            seqs = np.array([ctrl_seq[slots[j]] for j in sent])
            for j, data in zip(sent, pack_ctrl(ctrl, seqs, now if header else None)):
                answers[j] = data
        rest = later
    return answers


def step_round(bank: ControllerBank, slots: np.ndarray, meas: np.ndarray, backup: bool = False,
               meas_rows: np.ndarray | None = None) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Advance the controllers in ``slots`` by one sample each on ``meas`` (MEAS records, row r for
    ``slots[r]``: e.g. rows of :func:`sdvisc.wire_batch.decode_batch`'s array).

    Returns (valid, ctrl): ``valid[r]`` is True where slot r gave a usable output (started, finite
    measurements and outputs); ``ctrl`` holds the CTRL words of the valid rows, in row order: the
    :data:`CTRL_OUTPUTS`, ``wt``, ``meas_seq`` and ``flags`` -- all but the CTRL's own ``seq``.
    ``meas_rows``: ``meas``' MEAS_FIELDS as a float matrix if the caller has it already
    (:func:`sdvisc.wire_batch.float_rows`)."""
    out, valid = bank.step(slots, float_rows(meas, MEAS_FIELDS) if meas_rows is None else meas_rows)
    if valid.all():  # the usual case: every row answered, no selection
        ctrl = {k: out[k] for k in CTRL_OUTPUTS}
        ctrl.update(wt=meas["wt"], meas_seq=meas["seq"], flags=out["limited"].astype(int))  # FLAG_LIMITED: bit 0
    else:
        ctrl = {k: out[k][valid] for k in CTRL_OUTPUTS}
        ctrl.update(wt=meas["wt"][valid], meas_seq=meas["seq"][valid], flags=out["limited"][valid].astype(int))
    if backup:
        ctrl["flags"] |= FLAG_BACKUP
    return valid, ctrl


def pack_ctrl(ctrl: dict[str, np.ndarray], seqs: np.ndarray, now: float | None) -> list[bytes | None]:
    """The CTRL datagrams of :func:`step_round`'s ``ctrl`` numbered ``seqs``, with the VILLAS header
    stamped ``now`` (wall time, s; None: no header). Packed in one batch; a row with a value beyond
    float32 is None and the others are packed row by row."""
    cols = {**ctrl, "seq": seqs}
    header = None if now is None else (seqs, *header_time(now))
    try:
        return encode_batch(wire.MsgType.CTRL, cols, header=header)
    except wire.WireError:
        pass
    packets: list[bytes | None] = []
    for r in range(len(seqs)):
        row = {k: v[r:r + 1] for k, v in cols.items()}
        try:
            packets += encode_batch(wire.MsgType.CTRL, row,
                                    header=(seqs[r:r + 1], header[1], header[2]) if header else None)
        except wire.WireError:
            packets.append(None)
    return packets
