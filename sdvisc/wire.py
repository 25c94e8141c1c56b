"""GTNET-SKT framing and the message layouts of the SDViSC testbed, declared once.

A GTNET-SKT packet is a sequence of 4-byte big-endian words, each either a
signed 32-bit integer or an IEEE-754 float32.  The packet carries no
self-description: which word means what is fixed by :data:`LAYOUTS`.  When the
VILLASnode "fake" header is enabled (``header=True``, what the testbed uses) the
values are preceded by three 32-bit words: sequence number, timestamp seconds and
timestamp nanoseconds.  Word 0 of every message body is ``msg_type``.

:func:`encode` and :func:`decode` are strict and raise :class:`WireError` with a
machine-readable ``reason``; :class:`DecodeStats` is the counting, non-raising
variant for receive loops.  See ``docs/wire-format.md`` for the reference tables.
"""

from __future__ import annotations

import math
import operator
import struct
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, fields
from operator import itemgetter

from sdvisc.wire_layouts import (  # noqa: F401 - the layouts and addresses, re-exported: wire.MsgType, wire.turbine_id, …
    FLOAT32_MAX,
    HEADER_WORDS,
    INT32_MAX,
    INT32_MIN,
    LAYOUTS,
    MAX_WORDS,
    MSG_TYPE_FIELD,
    PORT_CONTROLLER,
    PORT_OWFCC,
    PORT_ROLES,
    PORT_SDC,
    PORT_TURBINE,
    REJECT_REASONS,
    UINT32_MAX,
    WORD_BYTES,
    Command,
    Field,
    MsgType,
    ParamMask,
    RejectReason,
    Status,
    i32_to_ip,
    ip_to_i32,
    is_turbine_id,
    parse_turbine,
    turbine_id,
    turbine_name,
)


@dataclass(frozen=True)
class Header:
    """The VILLASnode fake header: sequence number and origin timestamp (unsigned 32-bit words)."""

    seq: int
    sec: int
    nsec: int

    @classmethod
    def now(cls, seq: int) -> Header:
        """Header stamped with the current wall-clock time; ``seq`` wraps modulo 2**32."""
        sec, nsec = divmod(time.time_ns(), 1_000_000_000)
        return cls(seq & UINT32_MAX, sec & UINT32_MAX, nsec)

    @classmethod
    def at(cls, seq: int, t: float) -> Header:
        """Header stamped with time ``t`` (seconds, e.g. a reading of the run's clock)."""
        sec = int(t)
        return cls(seq & UINT32_MAX, sec & UINT32_MAX, min(int((t - sec) * 1e9), 999_999_999))

    @property
    def time(self) -> float:
        """Timestamp as float seconds."""
        return self.sec + self.nsec * 1e-9


@dataclass(frozen=True)
class Message:
    """A decoded message: its type, its named values (``msg_type`` excluded) and the header, if any."""

    type: MsgType
    values: dict[str, int | float]
    header: Header | None

    def __getitem__(self, name: str) -> int | float:
        if name == "msg_type":
            return int(self.type)
        return self.values[name]

    def encode(self) -> bytes:
        """The message back on the wire, with its header if it has one."""
        return encode(self.type, self.values, header=self.header)


class WireError(ValueError):
    """Any encode/decode failure; ``reason`` is one of :data:`REJECT_REASONS`."""

    def __init__(self, reason: RejectReason, detail: str) -> None:
        super().__init__(f"{reason}: {detail}")
        self.reason: RejectReason = reason
        self.detail = detail


_WORD_FORMAT = {"i32": "i", "f32": "f"}
_HEADER_FORMAT = "III"
_I32 = struct.Struct(">i")


def _picker(positions: tuple[int, ...]) -> Callable[[tuple], tuple]:
    """A fast function returning the items at ``positions`` of a tuple, always as a tuple."""
    if not positions:
        return lambda words: ()
    if len(positions) == 1:
        only = positions[0]
        return lambda words: (words[only],)
    return itemgetter(*positions)


class _Codec:
    """Precompiled struct and checks for one (message type, header) pair."""

    __slots__ = (
        "mtype", "header", "struct", "words", "first_value", "body_fields", "names", "name_set",
        "float_positions", "take_floats", "enum_checks",
    )

    def __init__(self, mtype: MsgType, header: bool) -> None:
        layout = LAYOUTS[mtype]
        self.mtype = mtype
        self.header = header
        body_format = "".join(_WORD_FORMAT[f.kind] for f in layout)
        self.struct = struct.Struct(">" + (_HEADER_FORMAT if header else "") + body_format)
        self.words = len(layout) + (HEADER_WORDS if header else 0)
        self.first_value = (HEADER_WORDS if header else 0) + 1
        self.body_fields = layout[1:]
        self.names = tuple(f.name for f in self.body_fields)
        self.name_set = frozenset(self.names)
        # Positions below index the value tuple that excludes the header and msg_type.
        self.float_positions = tuple(i for i, f in enumerate(self.body_fields) if f.kind == "f32")
        self.take_floats = _picker(self.float_positions)
        self.enum_checks = tuple(
            (i, f.name, frozenset(int(m) for m in f.enum))
            for i, f in enumerate(self.body_fields)
            if f.enum is not None
        )

    def pack(self, values: Mapping[str, int | float], header: Header | None) -> bytes:
        if values.keys() != self.name_set:
            values = self._conform(values)
        ordered = tuple(values[name] for name in self.names)
        self._check_floats(ordered)
        self._check_enums(ordered)
        prefix = (header.seq, header.sec, header.nsec) if header is not None else ()
        try:
            return self.struct.pack(*prefix, int(self.mtype), *ordered)
        except (struct.error, OverflowError, TypeError):
            raise self._pack_failure(ordered, header) from None

    def unpack(self, data: bytes) -> Message:
        words = self.struct.unpack(data)
        body = words[self.first_value:]
        self._check_floats(body)
        self._check_enums(body)
        header = Header(words[0], words[1], words[2]) if self.header else None
        return Message(self.mtype, dict(zip(self.names, body, strict=True)), header)

    def _conform(self, values: Mapping[str, int | float]) -> dict[str, int | float]:
        """``values`` without a consistent ``msg_type`` key; WireError("field") on any other mismatch."""
        given = dict(values)
        if "msg_type" in given:
            claimed = given.pop("msg_type")
            if claimed != int(self.mtype):
                raise WireError("field", f"msg_type {claimed!r} contradicts {self.mtype.name}")
        missing = sorted(self.name_set - given.keys())
        extra = sorted(given.keys() - self.name_set)
        if missing or extra:
            raise WireError("field", f"{self.mtype.name}: missing {missing}, unexpected {extra}")
        return given

    def _check_floats(self, body: tuple) -> None:
        # A sum of float32-sized values is finite exactly when every term is finite.
        try:
            if math.isfinite(sum(self.take_floats(body))):
                return
        except TypeError:
            pass  # a non-number; struct.pack reports it as a "field" error
        for i in self.float_positions:
            try:
                finite = math.isfinite(body[i])
            except TypeError:
                continue
            if not finite:
                raise WireError("nonfinite", f"{self.mtype.name}.{self.names[i]} = {body[i]!r}")

    def _check_enums(self, body: tuple) -> None:
        for i, name, allowed in self.enum_checks:
            try:
                known = body[i] in allowed
            except TypeError:
                raise WireError("field", f"{self.mtype.name}.{name} = {body[i]!r} is not an integer") from None
            if not known:
                raise WireError("range", f"{self.mtype.name}.{name} = {body[i]!r} is not a valid code")

    def _pack_failure(self, ordered: tuple, header: Header | None) -> WireError:
        """Explain why struct could not pack ``ordered``."""
        if header is not None:
            for name in ("seq", "sec", "nsec"):
                word = getattr(header, name)
                try:
                    fits = 0 <= operator.index(word) <= UINT32_MAX
                except TypeError:
                    return WireError("field", f"header.{name} = {word!r} is not an integer")
                if not fits:
                    return WireError("range", f"header.{name} = {word!r} is not an unsigned 32-bit integer")
        for field, value in zip(self.body_fields, ordered, strict=True):
            where = f"{self.mtype.name}.{field.name} = {value!r}"
            if field.kind == "i32":
                try:
                    number = operator.index(value)
                except TypeError:
                    return WireError("field", f"{where} is not an integer")
                if not INT32_MIN <= number <= INT32_MAX:
                    return WireError("range", f"{where} does not fit in int32")
            else:
                try:
                    magnitude = abs(float(value))
                except (TypeError, ValueError):
                    return WireError("field", f"{where} is not a number")
                if magnitude > FLOAT32_MAX:
                    return WireError("range", f"{where} does not fit in float32")
        return WireError("field", f"{self.mtype.name}: values cannot be packed")


_CODECS: dict[tuple[int, bool], _Codec] = {
    (int(mtype), header): _Codec(mtype, header) for mtype in MsgType for header in (False, True)
}


def word_count(mtype: MsgType, *, header: bool) -> int:
    """Number of 4-byte words of a ``mtype`` packet."""
    return _CODECS[(int(mtype), header)].words


def packer(mtype: MsgType, *, header: bool) -> struct.Struct:
    """The ``struct`` of a ``mtype`` datagram: header words (if any), ``msg_type``, the fields."""
    return _CODECS[(int(mtype), header)].struct


def field_names(mtype: MsgType) -> tuple[str, ...]:
    """Names that :func:`encode` expects for ``mtype`` (the layout without ``msg_type``)."""
    return _CODECS[(int(mtype), False)].names


def encode(mtype: MsgType, values: Mapping[str, int | float], *, header: Header | None = None) -> bytes:
    """Pack one message; raises :class:`WireError` on missing/extra fields, NaN/Inf or out-of-range values."""
    codec = _CODECS.get((mtype, header is not None))
    if codec is None:
        raise WireError("type", f"unknown message type {mtype!r}")
    return codec.pack(values, header)


def decode(data: bytes, *, header: bool) -> Message:
    """Unpack one datagram strictly; raises :class:`WireError` if it is not a valid testbed message."""
    size = len(data)
    if size % WORD_BYTES:
        raise WireError("length", f"{size} bytes is not a whole number of 4-byte words")
    words = size // WORD_BYTES
    if words > MAX_WORDS:
        raise WireError("length", f"{words} words exceeds the GTNET-SKT maximum of {MAX_WORDS}")
    type_word = HEADER_WORDS if header else 0
    if words <= type_word:
        raise WireError("length", f"{words} words leaves no room for msg_type")
    raw_type = _I32.unpack_from(data, type_word * WORD_BYTES)[0]
    codec = _CODECS.get((raw_type, header))
    if codec is None:
        raise WireError("type", f"unknown msg_type {raw_type}")
    if words != codec.words:
        raise WireError("length", f"{codec.mtype.name} needs {codec.words} words, got {words}")
    return codec.unpack(data)


@dataclass
class DecodeStats:
    """Counts decoded and rejected datagrams per reason; :meth:`decode` never raises :class:`WireError`."""

    ok: int = 0
    length: int = 0
    type: int = 0
    nonfinite: int = 0
    range: int = 0
    field: int = 0

    def decode(self, data: bytes, *, header: bool) -> Message | None:
        """Decode ``data``, count the outcome, return the message or None if rejected."""
        try:
            message = decode(data, header=header)
        except WireError as error:
            setattr(self, error.reason, getattr(self, error.reason) + 1)
            return None
        self.ok += 1
        return message

    @property
    def rejected(self) -> int:
        """Total rejected datagrams, all reasons."""
        return sum(getattr(self, reason) for reason in REJECT_REASONS)

    def as_dict(self) -> dict[str, int]:
        """All counters plus ``rejected``."""
        counts = {f.name: getattr(self, f.name) for f in fields(self)}
        counts["rejected"] = self.rejected
        return counts
