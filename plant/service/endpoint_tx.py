"""What a turbine endpoint sends each step: its MEAS datagram, written as :func:`sdvisc.wire.encode`
writes it, in one ``struct`` call (the plant sends one per streaming turbine and step: the
general encoder's field-by-field checks cost several times the packing). Pure code: no socket."""

from __future__ import annotations

import math
import struct

from sdvisc import wire

_MEAS = int(wire.MsgType.MEAS)


class MeasPacker:
    """MEAS datagrams with or without the VILLAS header (its ``seq`` = the MEAS ``seq``)."""

    def __init__(self, header: bool) -> None:
        self.header = header
        self._pack = wire.packer(wire.MsgType.MEAS, header=header).pack

    def pack(self, wid: int, seq: int, t_sim: float, values, sec: int, nsec: int) -> bytes | None:
        """The datagram of turbine ``wid``'s sample ``seq`` (``values``: the MEAS_FIELDS in order,
        ``sec``/``nsec``: the header's send time); None where :func:`sdvisc.wire.encode` would refuse
        it (a non-finite value, one beyond float32, a number that does not fit its word)."""
        if not math.isfinite(t_sim + sum(values)):  # a NaN or an infinity anywhere makes the sum non-finite
            return None
        try:
            if self.header:
                return self._pack(seq, sec, nsec, _MEAS, wid, seq, t_sim, *values)
            return self._pack(_MEAS, wid, seq, t_sim, *values)
        except (struct.error, OverflowError):
            return None
