"""What an SDC answer is, for the compiled and the numpy stepping alike (no numba here: the service
imports this also without the compiler): the codes of :func:`sdc_unit.ctrl_jit.meas_to_ctrl`, the
CTRL flag bits, the header's time words and the datagram's length."""

from __future__ import annotations

from sdvisc import wire

SENT, NOT_STEPPED, UNENCODABLE = 0, 1, 2
"""The CTRL is written; the turbine gave no usable output (inactive or a non-finite output: no CTRL,
its ``seq`` not used); an output or number does not fit its word (no CTRL and its ``seq`` used, as
:func:`sdc_unit.round.pack_ctrl` does)."""
FLAG_LIMITED = 1
"""``CTRL.flags`` bit 0: the current limiter is active."""
FLAG_BACKUP = 2
"""``CTRL.flags`` bit 1: the answer comes from a backup SDC."""


def ctrl_bytes(header: bool) -> int:
    """Length of a CTRL datagram."""
    return (len(wire.LAYOUTS[wire.MsgType.CTRL]) + (wire.HEADER_WORDS if header else 0)) * wire.WORD_BYTES


def header_time(now: float) -> tuple[int, int]:
    """The (sec, nsec) words of a CTRL header stamped ``now`` (s)."""
    sec = int(now)
    return sec, int((now - sec) * 1e9)
