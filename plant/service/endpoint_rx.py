"""What a turbine endpoint does with one received datagram: the plant's receive step, without
sockets, clock or model, so it can be tested on its own.

:func:`receive` decodes one datagram that arrived on a turbine's socket and decides: a ``CTRL`` to
apply, a ``REQUEST`` to carry out, or nothing. Whatever it does not accept it counts in the
endpoint's counters, once, under one reason; it never raises, whatever the input:

* ``rx_rejected`` — every rejected datagram, and ``rx_reject_<reason>`` per reason:

  ``length``, ``type``, ``nonfinite``, ``range``, ``field``
      the datagram is not a valid testbed message (:func:`sdvisc.wire.decode`'s reasons);
  ``unexpected_type``
      a valid message other than ``CTRL``/``REQUEST`` (nothing else is sent to a turbine);
  ``wrong_turbine``
      its ``wt`` is another turbine's;
  ``not_from_sdc``
      a ``CTRL`` whose source IP is not the SDC named by ``STREAM_START`` (or none named yet).
      After an SDC failover the switches rewrite the substitute's packets to come from the
      addressed (primary) SDC, so genuine control keeps passing;
  ``not_from_controller``
      a ``REQUEST`` whose source IP is not the SDN application's virtual IP (the only sender of
      requests to a turbine), so no other host can start, stop or redirect a turbine's stream;
  ``future_seq``
      a ``CTRL`` answering a measurement not sent yet (``meas_seq`` above the newest ``MEAS`` seq):
      impossible for a genuine answer, and accepting it would make every later genuine ``CTRL``
      look stale and silently stop control;
  ``out_of_range``
      a ``CTRL`` whose voltage or current reference exceeds :data:`MAX_REF_PU` in magnitude;
  ``bad_request``
      a ``REQUEST`` other than ``STREAM_START``/``STREAM_STOP``, or a ``STREAM_START`` whose
      ``sdc_ip`` is not a unicast address;
  ``internal``
      handling the datagram raised (counted by the caller with :func:`count_internal`).

* ``ctrl_stale`` — a well-formed ``CTRL`` answering a measurement no newer than one already
  applied (a duplicate, or overtaken): expected traffic around a failover, so it is not counted
  in ``rx_rejected``.

In ``plant_stats.json`` the counters are under ``turbines.<name>`` (a reason only once it
occurred) and their sums over all turbines, by reason, under ``rx_rejected``. The plant config
``check_rx_source: false`` switches the two source checks off.
"""

from __future__ import annotations

import math
import sys
import traceback

from sdvisc import wire

MAX_REF_PU = 10.0
"""Largest plausible magnitude of a ``CTRL`` voltage reference (v_ref_d, v_ref_q) or current
reference (i_ref_d, i_ref_q), in p.u. of the turbine rating. A genuine SDC limits the current to
``i_max`` (1.5 p.u.) and the converter voltage stays near 1 p.u.; beyond 10 p.u. the packet cannot
be a controller output and is dropped. This bound only filters packets: it is never applied to the
model."""

APPLY = "apply"
"""Action: a CTRL newer than any applied so far (``ep.ctrl_seq`` already records it)."""
REQUEST = "request"
"""Action: a STREAM_START/STREAM_STOP for this turbine."""
IGNORE = "ignore"
"""Action: nothing to do; the datagram was counted."""

REASONS: tuple[str, ...] = wire.REJECT_REASONS + (
    "unexpected_type", "wrong_turbine", "not_from_controller", "bad_request", "not_from_sdc", "future_seq",
    "out_of_range", "internal")
"""Every reason counted as ``rx_reject_<reason>`` (and in ``rx_rejected``)."""

TURBINE_COMMANDS = frozenset({int(wire.Command.STREAM_START), int(wire.Command.STREAM_STOP)})

_IGNORED = (IGNORE, None)


def reject(counts: dict, reason: str) -> tuple[str, None]:
    """Count one rejected datagram under ``reason``; the IGNORE action."""
    counts["rx_rejected"] = counts.get("rx_rejected", 0) + 1
    key = "rx_reject_" + reason
    counts[key] = counts.get(key, 0) + 1
    return _IGNORED


def is_unicast_word(word: int) -> bool:
    """``word`` (an IPv4 address as carried in an i32 word) is a usable unicast address: not in
    0.0.0.0/8, multicast 224.0.0.0/4, or 240.0.0.0/4 (reserved, and the broadcast address)."""
    return 0 < ((word & wire.UINT32_MAX) >> 24) < 224


def receive(ep, data: bytes, addr, *, header: bool, controller_ip: str | None,
            stats: wire.DecodeStats | None = None, check_source: bool = True) -> tuple[str, wire.Message | None]:
    """Decide what turbine endpoint ``ep`` does with ``data``, received from ``addr`` (ip, port).

    Returns (:data:`APPLY`, ctrl), (:data:`REQUEST`, request) or (:data:`IGNORE`, None). Reads
    ``ep.wid``, ``ep.sdc_addr`` and ``ep.meas_seq`` (the newest MEAS seq sent); an accepted CTRL
    advances ``ep.ctrl_seq``; every datagram not accepted is counted in ``ep.counts`` (see the
    module docstring). ``controller_ip`` is the SDN application's virtual IP; ``stats`` also counts
    the wire-level outcome (decoded or rejected by reason); ``check_source`` False accepts REQUEST
    and CTRL from any address.
    """
    counts = ep.counts
    try:
        msg = wire.decode(data, header=header)
    except wire.WireError as error:
        if stats is not None:
            setattr(stats, error.reason, getattr(stats, error.reason) + 1)
        return reject(counts, error.reason)
    if stats is not None:
        stats.ok += 1
    mtype = msg.type
    if mtype != wire.MsgType.CTRL and mtype != wire.MsgType.REQUEST:
        return reject(counts, "unexpected_type")
    if msg["wt"] != ep.wid:
        return reject(counts, "wrong_turbine")
    if mtype == wire.MsgType.REQUEST:
        if check_source and addr[0] != controller_ip:
            return reject(counts, "not_from_controller")
        cmd = msg["cmd"]
        if cmd not in TURBINE_COMMANDS or (cmd == wire.Command.STREAM_START and not is_unicast_word(msg["sdc_ip"])):
            return reject(counts, "bad_request")
        return REQUEST, msg
    if check_source and (ep.sdc_addr is None or addr[0] != ep.sdc_addr[0]):
        return reject(counts, "not_from_sdc")
    values = msg.values
    meas_seq = values["meas_seq"]
    if meas_seq > ep.meas_seq:
        return reject(counts, "future_seq")
    # finite (decode checked), so hypot is too
    if (math.hypot(values["v_ref_d"], values["v_ref_q"]) > MAX_REF_PU
            or math.hypot(values["i_ref_d"], values["i_ref_q"]) > MAX_REF_PU):
        return reject(counts, "out_of_range")
    # ordered by the measurement it answers (our own counter, whichever SDC answered it):
    # a duplicate or out-of-order answer is never applied after a newer one
    if meas_seq <= ep.ctrl_seq:
        counts["ctrl_stale"] = counts.get("ctrl_stale", 0) + 1
        return _IGNORED
    ep.ctrl_seq = meas_seq
    return APPLY, msg


_internal_logged: set[str] = set()


def count_internal(counts: dict, error: BaseException, where: str = "plant") -> None:
    """Count a datagram whose handling raised ``error`` (``rx_reject_internal``); the first one per
    ``where`` is logged to stderr with its traceback, later ones only counted."""
    reject(counts, "internal")
    if where not in _internal_logged:
        _internal_logged.add(where)
        print(f"{where}: handling a received datagram raised {type(error).__name__}: {error}; dropped and "
              "counted as rx_reject_internal (further ones are only counted)", file=sys.stderr)
        traceback.print_exception(type(error), error, error.__traceback__, file=sys.stderr)


def rejections_by_reason(all_counts) -> dict[str, int]:
    """Sum of ``rx_reject_<reason>`` over several endpoints' counters, by reason (non-zero only)."""
    total: dict[str, int] = {}
    for counts in all_counts:
        for key, n in counts.items():
            if key.startswith("rx_reject_") and n:
                reason = key[len("rx_reject_"):]
                total[reason] = total.get(reason, 0) + n
    return dict(sorted(total.items()))
