"""What the SDC service lets through to a controller, as pure code (no socket, no clock).

A datagram that decodes is not yet a measurement to act on. One SDC serves every turbine, so
one bad datagram — mutated in flight, sent by a faulty endpoint or by an attacker on a turbine's
own port — must be dropped and counted, never applied, and never stop the service. The checks,
in order (:meth:`sdc_unit.core.SdcCore._admit`, for every MEAS whatever the batch), each with the
reason it is counted under (``SdcCore.rejected``):

* ``unknown_turbine``: ``wt`` is not a turbine id (cluster*100 + number);
* ``unserved``: a turbine the SDC was not told to serve (no START_INSTANCE; a backup follows the
  mirrored turbines while it has free slots);
* ``out_of_range``: a measurement no converter can produce (any per-unit value beyond
  :data:`MEAS_ABS_MAX_PU`, a negative or absurd ``t_sim``);
* ``stale``: ``seq`` not newer than the last one used (duplicate or out of order);
* ``inconsistent``: ``seq`` and ``t_sim`` disagree with the turbine's stream. A genuine stream
  advances both together (one sample = one ``seq`` = one Ts of ``t_sim``, also across lost
  samples), so a datagram whose ``seq`` or ``t_sim`` was altered is recognised even when it is
  newer. A real jump (the plant restarted, the stream was stopped and started) is accepted once a
  second datagram confirms it (:class:`SeqGate`): the price is one sample at such a restart. Late
  datagrams of the stream itself (``seq`` and ``t_sim`` on its line, behind it) are ``stale``, however
  many come in a row: they never confirm a restart.
  Without this check one datagram with ``seq = 2**31 - 1`` would make every later genuine sample
  "stale" and silently end the turbine's control.

Commands (REQUEST) are accepted only from the SDN application's address (``not_controller``)
and with parameters inside :data:`PARAM_LIMITS` (``bad_params``; answered ``REFUSED``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from sdvisc import vocabulary, wire
from sdvisc.vocabulary import MEAS_FIELDS, VISC_PARAMS

MEAS_ABS_MAX_PU = 100.0
"""Largest magnitude of a per-unit measurement (voltage, current, power, DC voltage, frequency)."""
T_SIM_MAX_S = 1e7
"""Largest plausible simulation time in a MEAS, s (only garbage is beyond it)."""
CONFIRM_WINDOW = 32
"""A jump is confirmed by a later datagram at most this many samples after it."""

PARAM_LIMITS = vocabulary.PARAM_LIMITS
"""Accepted range of each parameter a REQUEST can set (only the bits of its ``mask`` count; ``supp``
is a bit field, any value is a valid one): declared with the wire's words
(:data:`sdvisc.wire_layouts.RUNTIME_PARAM_WORDS`)."""


def t_sim_tolerance(t_sim: float, step_s: float) -> float:
    """How far a genuine ``t_sim`` may sit from ``seq``'s expectation: half a sample plus the
    float32 rounding of both times (``t_sim`` travels as float32)."""
    return 0.5 * step_s + 2.0 * math.ulp(max(abs(t_sim), 1.0)) * 2.0**29  # 2 float32 ulps


def meas_out_of_range(values: dict) -> bool:
    """True if a decoded MEAS (its values by name) holds a value no converter can produce."""
    return values_out_of_range(values["t_sim"], [values[k] for k in MEAS_FIELDS])


_BEYOND = MEAS_ABS_MAX_PU.__lt__  # |x| > the limit (False for NaN: the wire check rejects NaN before)


def values_out_of_range(t_sim: float, values) -> bool:
    """:func:`meas_out_of_range` of one MEAS given as plain floats: its ``t_sim`` and MEAS_FIELDS."""
    return t_sim < 0.0 or t_sim > T_SIM_MAX_S or any(map(_BEYOND, map(abs, values)))


def bad_params(values: dict) -> list[str]:
    """Names of the parameters a REQUEST marks (``mask``) whose value is outside PARAM_LIMITS."""
    mask = int(values.get("mask", 0))
    bad = []
    for name, (lo, hi) in PARAM_LIMITS.items():
        if mask & VISC_PARAMS[name] and not lo <= values[name] <= hi:
            bad.append(name)
    return bad


@dataclass
class SeqGate:
    """Per-turbine sequence and time consistency of a MEAS stream (see the module docstring)."""

    step_s: float
    last_seq: int = -1
    last_t: float = 0.0
    candidate: tuple[int, float] | None = None

    def reset(self) -> None:
        """A new stream starts (START_INSTANCE): the next datagram is taken as its first."""
        self.last_seq, self.last_t, self.candidate = -1, 0.0, None

    def _consistent(self, seq: int, t_sim: float, ref: tuple[int, float]) -> bool:
        expected = ref[1] + (seq - ref[0]) * self.step_s
        return abs(t_sim - expected) <= t_sim_tolerance(max(t_sim, ref[1]), self.step_s)

    def admit(self, seq: int, t_sim: float) -> str | None:
        """None if the sample is to be used (and becomes the last one), else the reject reason."""
        if self.last_seq < 0:
            self._accept(seq, t_sim)
            return None
        if seq > self.last_seq and self._consistent(seq, t_sim, (self.last_seq, self.last_t)):
            self._accept(seq, t_sim)
            return None
        cand = self.candidate
        if cand is not None and cand[0] < seq <= cand[0] + CONFIRM_WINDOW and self._consistent(seq, t_sim, cand):
            self._accept(seq, t_sim)  # a second datagram confirms the jump: the stream restarted
            return None
        if seq <= self.last_seq and self._consistent(seq, t_sim, (self.last_seq, self.last_t)):
            # a late or repeated datagram of this very stream, never evidence of a restart: a burst of
            # them (a failed port's queue released when the link came back, 300 ms old on AF_XDP
            # ports) was taken for a restarted stream and stepped the controllers back in time
            return "stale"
        self.candidate = (seq, t_sim)
        return "inconsistent"

    def _accept(self, seq: int, t_sim: float) -> None:
        self.last_seq, self.last_t, self.candidate = seq, t_sim, None


def turbine_ok(wid: int) -> bool:
    """``wid`` names a turbine (cluster*100 + number, both ≥ 1)."""
    return wire.is_turbine_id(wid)
