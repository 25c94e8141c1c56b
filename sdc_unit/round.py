"""One SDC round as pure code: a batch of MEAS records in, the batch of CTRL values out.

No socket, no clock, no per-turbine bookkeeping. :mod:`sdc_unit.service` admits the datagrams
before (:mod:`sdc_unit.admission`), numbers the answers and sends them after;
``benchmarks/sdc_throughput.py`` times exactly these two functions. A round steps every turbine in
it together (one vectorised call); a turbine appears at most once in a round.
"""

from __future__ import annotations

import numpy as np

from sdvisc import wire
from sdvisc.vocabulary import CTRL_OUTPUTS, MEAS_FIELDS
from sdvisc.wire_batch import encode_batch, float_rows

from .bank import ControllerBank

FLAG_LIMITED = 1
"""``CTRL.flags`` bit 0: the current limiter is active."""
FLAG_BACKUP = 2
"""``CTRL.flags`` bit 1: the answer comes from a backup SDC."""


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


def header_time(now: float) -> tuple[int, int]:
    """The (sec, nsec) words of a CTRL header stamped ``now`` (s)."""
    sec = int(now)
    return sec, int((now - sec) * 1e9)


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
