"""What the SDC's one-datagram path (:func:`sdc_unit.ctrl_jit.meas_to_ctrl`) hands back, for the
service that sends its answer (no numba here: the service imports this also without the compiler)."""

from __future__ import annotations

from sdvisc import wire

SENT, NOT_STEPPED, UNENCODABLE = 0, 1, 2
"""The CTRL is written; the turbine gave no usable output (inactive or a non-finite output: no CTRL,
its ``seq`` not used); an output or number does not fit its word (no CTRL and its ``seq`` used, as
:func:`sdc_unit.round.pack_ctrl` does)."""


def ctrl_bytes(header: bool) -> int:
    """Length of a CTRL datagram."""
    return (len(wire.LAYOUTS[wire.MsgType.CTRL]) + (wire.HEADER_WORDS if header else 0)) * wire.WORD_BYTES
