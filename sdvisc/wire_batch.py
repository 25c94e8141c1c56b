"""Many GTNET-SKT datagrams of one message type at once, as numpy record arrays.

The per-datagram :func:`sdvisc.wire.decode`/:func:`~sdvisc.wire.encode` cost a few microseconds
each in Python; an SDC answering 50 turbines every 0.67 ms cannot afford 100 of them per sample.
Here the layouts of :data:`sdvisc.wire.LAYOUTS` become big-endian numpy record dtypes, so a
receive batch is decoded, checked and converted with a handful of vectorised calls, and a reply
batch is packed with one ``tobytes``. The rules are those of :mod:`sdvisc.wire` and nothing is
looser: a datagram of the wrong length or type, with a NaN/Inf float or an unknown enum code is
rejected and counted (``DecodeStats``) and never appears in the result; :func:`encode_batch`
raises :class:`~sdvisc.wire.WireError` on a non-finite or out-of-range value, naming the row and
the field.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Mapping, Sequence
from functools import cache
from operator import itemgetter

import numpy as np

from sdvisc.wire import (
    FLOAT32_MAX,
    HEADER_WORDS,
    INT32_MAX,
    INT32_MIN,
    LAYOUTS,
    UINT32_MAX,
    WORD_BYTES,
    DecodeStats,
    MsgType,
    WireError,
)
from sdvisc.wire import packer as wire_packer

HEADER_FIELDS = ("hdr_seq", "hdr_sec", "hdr_nsec")
"""Record fields of the VILLASnode header words (unsigned 32-bit)."""

SMALL_BATCH = 8
"""Up to this many rows, :func:`encode_batch` packs row by row with ``struct`` (fewer calls)."""


@cache
def record_dtype(mtype: MsgType, header: bool) -> np.dtype:
    """The big-endian record dtype of one ``mtype`` datagram (header fields first when ``header``)."""
    fields = [(name, ">u4") for name in HEADER_FIELDS] if header else []
    fields += [(f.name, ">i4" if f.kind == "i32" else ">f4") for f in LAYOUTS[mtype]]
    return np.dtype(fields)


@cache
def _float_columns(mtype: MsgType, header: bool) -> np.ndarray:
    first = HEADER_WORDS if header else 0
    return np.array([first + i for i, f in enumerate(LAYOUTS[mtype]) if f.kind == "f32"], dtype=np.intp)


@cache
def _enum_fields(mtype: MsgType) -> tuple:
    return tuple((f.name, np.array([int(m) for m in f.enum])) for f in LAYOUTS[mtype][1:] if f.enum is not None)


_TYPE_WORD: dict[tuple, tuple[int, int, bytes]] = {}
"""(mtype, header) -> (datagram length, offset of the type word, the type word's bytes), for :func:`is_type`."""


def is_type(data: bytes, mtype: MsgType, header: bool) -> bool:
    """Cheap pre-sort of a receive batch: ``data`` has ``mtype``'s length and type word (the full
    checks are :func:`decode_batch`'s)."""
    key = (mtype, header)
    found = _TYPE_WORD.get(key)
    if found is None:
        at = (HEADER_WORDS if header else 0) * WORD_BYTES
        found = _TYPE_WORD[key] = (record_dtype(mtype, header).itemsize, at, int(mtype).to_bytes(4, "big", signed=True))
    size, at, word = found
    return len(data) == size and data[at:at + 4] == word


@cache
def _word_span(dtype: np.dtype, names: tuple[str, ...]) -> tuple[int, int] | None:
    """(first word, words per record) when ``names`` are consecutive 4-byte float fields of the
    packed record ``dtype``, else None."""
    if dtype.itemsize % WORD_BYTES:
        return None
    offsets = [dtype.fields[name][1] for name in names]
    kinds = {dtype.fields[name][0].str for name in names}
    if kinds != {">f4"} or offsets != list(range(offsets[0], offsets[0] + WORD_BYTES * len(names), WORD_BYTES)):
        return None
    return offsets[0] // WORD_BYTES, dtype.itemsize // WORD_BYTES


def float_rows(records: np.ndarray, names: Sequence[str]) -> np.ndarray:
    """The float fields ``names`` of a record array as a (len(names), len(records)) float64 matrix,
    row i = ``records[names[i]]`` (exactly: float32 widens to float64 without rounding). Consecutive
    fields of a contiguous array are taken in one strided copy."""
    names = tuple(names)
    span = _word_span(records.dtype, names) if records.ndim == 1 and records.flags.c_contiguous else None
    if span is None:
        return np.array([records[name] for name in names], dtype=float)
    first, width = span
    words = records.view(records.dtype.fields[names[0]][0]).reshape(len(records), width)
    return np.ascontiguousarray(words[:, first:first + len(names)].T, dtype=float)


def decode_batch(datagrams: Sequence[bytes], mtype: MsgType, *, header: bool,
                 stats: DecodeStats | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Decode ``datagrams`` that should all be ``mtype``.

    Returns (records, index): the accepted datagrams as a record array (``record_dtype``, big-endian;
    read-only when every datagram was accepted) and their positions in ``datagrams``. Rejected
    ones are counted in ``stats`` by reason.
    """
    dtype = record_dtype(mtype, header)
    if len(datagrams) <= SMALL_BATCH:
        return _decode_rows(datagrams, mtype, header, stats, dtype)
    size = dtype.itemsize
    if set(map(len, datagrams)) == {size}:  # the usual case: every datagram has the right length
        sized = range(len(datagrams))
        joined = b"".join(datagrams)
    else:
        sized = [i for i, d in enumerate(datagrams) if len(d) == size]
        joined = b"".join(datagrams[i] for i in sized)
    if stats is not None:
        stats.length += len(datagrams) - len(sized)
    if not sized:
        return np.zeros(0, dtype=dtype), np.zeros(0, dtype=np.intp)
    words = np.frombuffer(joined, dtype=">f4").reshape(len(sized), size // WORD_BYTES)
    records = np.frombuffer(joined, dtype=dtype)
    type_ok = records["msg_type"] == int(mtype)
    finite = np.isfinite(words[:, _float_columns(mtype, header)]).all(axis=1)
    ok = type_ok & finite
    enum_ok = True
    for name, codes in _enum_fields(mtype):
        enum_ok = enum_ok & np.isin(records[name], codes)
    ok &= enum_ok
    if ok.all():  # the usual case: a read-only big-endian view of the received bytes, no copy
        if stats is not None:
            stats.ok += len(sized)
        return records, np.asarray(sized, dtype=np.intp)
    if stats is not None:
        stats.type += int(np.count_nonzero(~type_ok))
        stats.nonfinite += int(np.count_nonzero(type_ok & ~finite))
        stats.range += int(np.count_nonzero(type_ok & finite & ~enum_ok))
        stats.ok += int(np.count_nonzero(ok))
    index = np.asarray(sized, dtype=np.intp)[ok]
    return records[ok], index


@cache
def _check_plan(mtype: MsgType, header: bool) -> tuple:
    """What :func:`_decode_rows` checks in a ``mtype`` datagram's words: the type word's position,
    the float words, the enum words with their codes, and the unpacker."""
    first = HEADER_WORDS if header else 0
    layout = LAYOUTS[mtype]
    floats = tuple(first + i for i, f in enumerate(layout) if f.kind == "f32")
    enums = tuple((first + i, frozenset(int(m) for m in f.enum)) for i, f in enumerate(layout) if i and f.enum is not None)
    return first, _take(floats), enums, wire_packer(mtype, header=header).unpack


def _decode_rows(datagrams: Sequence[bytes], mtype: MsgType, header: bool, stats: DecodeStats | None,
                 dtype: np.dtype) -> tuple[np.ndarray, np.ndarray]:
    """decode_batch for a few datagrams: the checks one ``struct.unpack`` each, in the order and with
    the reasons of the numpy path, then the accepted bytes as one record array."""
    type_at, take_floats, enums, unpack = _check_plan(mtype, header)
    size, code = dtype.itemsize, int(mtype)
    kept: list[int] = []
    length = wrong_type = nonfinite = out_of_range = 0
    for i, data in enumerate(datagrams):
        if len(data) != size:
            length += 1
            continue
        words = unpack(data)
        if words[type_at] != code:
            wrong_type += 1
        elif not math.isfinite(sum(take_floats(words))):  # float32 values: the sum is finite iff each is
            nonfinite += 1
        elif any(words[at] not in codes for at, codes in enums):
            out_of_range += 1
        else:
            kept.append(i)
    if stats is not None:
        stats.length += length
        stats.type += wrong_type
        stats.nonfinite += nonfinite
        stats.range += out_of_range
        stats.ok += len(kept)
    if len(kept) == len(datagrams) and kept:  # the usual case: a read-only view of the received bytes
        return np.frombuffer(b"".join(datagrams), dtype=dtype), np.arange(len(kept), dtype=np.intp)
    if not kept:
        return np.zeros(0, dtype=dtype), np.zeros(0, dtype=np.intp)
    return np.frombuffer(b"".join(datagrams[i] for i in kept), dtype=dtype).copy(), np.array(kept, dtype=np.intp)


def _take(positions: tuple[int, ...]):
    """A function returning the tuple of the values at ``positions`` (itemgetter's, also for 0 or 1)."""
    if len(positions) == 1:
        return lambda values, at=positions[0]: (values[at],)
    return itemgetter(*positions) if positions else (lambda values: ())


@cache
def _columns(mtype: MsgType, header: bool) -> tuple:
    first = HEADER_WORDS if header else 0
    body = list(enumerate(LAYOUTS[mtype]))[1:]
    floats = tuple((first + i, f.name) for i, f in body if f.kind == "f32")
    ints = tuple((first + i, f.name) for i, f in body if f.kind == "i32")
    return floats, ints, frozenset(name for _, name in floats + ints)


def encode_batch(mtype: MsgType, columns: Mapping[str, np.ndarray | int | float], *,
                 header: tuple | None = None) -> list[bytes]:
    """Pack one datagram per row. ``columns`` maps every field of ``mtype`` (not ``msg_type``) to
    an array (or a scalar shared by all rows); ``header`` is (seq, sec, nsec), arrays or scalars,
    or None for no header. Raises WireError on a missing/unknown field, a NaN/Inf or a value that
    does not fit its word."""
    floats, ints, names = _columns(mtype, header is not None)
    if columns.keys() != names:
        raise WireError("field", f"{mtype.name}: missing {sorted(names - set(columns))}, "
                                 f"unexpected {sorted(set(columns) - names)}")
    rows = max((len(v) if type(v) is np.ndarray and v.ndim == 1 else np.size(v) for v in columns.values()), default=0)
    if rows <= SMALL_BATCH:
        return _encode_rows(mtype, columns, header, rows)
    words = np.empty((rows, record_dtype(mtype, header is not None).itemsize // WORD_BYTES), dtype=">u4")
    try:  # one call when every float column is an array of the full length
        f = np.array([columns[name] for _, name in floats], dtype=float).T
        if f.shape != (rows, len(floats)):
            raise ValueError
    except ValueError:
        f = np.empty((rows, len(floats)))
        for j, (_, name) in enumerate(floats):
            f[:, j] = columns[name]
    bad = ~(np.abs(f) <= FLOAT32_MAX)  # NaN compares False: caught here too
    if bad.any():
        row, j = (int(x[0]) for x in np.nonzero(bad))
        reason = "range" if np.isfinite(f[row, j]) else "nonfinite"
        raise WireError(reason, f"{mtype.name}.{floats[j][1]} = {f[row, j]!r} (row {row})")
    words[:, [c for c, _ in floats]] = f.astype(">f4").view(">u4")
    ints = (((HEADER_WORDS if header is not None else 0), "msg_type"),) + ints
    i = np.empty((rows, len(ints)), dtype=np.int64)
    i[:, 0] = int(mtype)
    for j, (_, name) in enumerate(ints[1:], start=1):
        i[:, j] = columns[name]
    bad = (i < INT32_MIN) | (i > INT32_MAX)
    if bad.any():
        row, j = (int(x[0]) for x in np.nonzero(bad))
        raise WireError("range", f"{mtype.name}.{ints[j][1]} = {int(i[row, j])} (row {row}) does not fit in int32")
    words[:, [c for c, _ in ints]] = i.astype(">i4").view(">u4")
    if header is not None:
        h = np.empty((rows, HEADER_WORDS), dtype=np.int64)
        for j, value in enumerate(header):
            h[:, j] = value
        bad = (h < 0) | (h > UINT32_MAX)
        if bad.any():
            row, j = (int(x[0]) for x in np.nonzero(bad))
            raise WireError("range", f"header.{HEADER_FIELDS[j][4:]} = {int(h[row, j])} is not an unsigned 32-bit integer")
        words[:, :HEADER_WORDS] = h
    size = words.shape[1] * WORD_BYTES
    buf = words.tobytes()
    return [buf[k:k + size] for k in range(0, rows * size, size)]


def _as_list(value, rows: int) -> list:
    if isinstance(value, np.ndarray) and value.ndim == 1:
        if len(value) != rows:
            raise WireError("field", f"column of {len(value)} values for {rows} rows")
        return value.tolist()
    if type(value) is int or type(value) is float:
        return [value] * rows
    if np.ndim(value) == 0:
        return [value.item() if isinstance(value, np.generic) else value] * rows
    return np.broadcast_to(value, (rows,)).tolist()


@cache
def _row_plan(mtype: MsgType, header: bool) -> tuple:
    """What :func:`_encode_rows` needs of ``mtype``: its fields, the float positions, the packer."""
    layout = LAYOUTS[mtype][1:]
    float_at = tuple(j for j, f in enumerate(layout) if f.kind == "f32")
    return layout, float_at, _take(float_at), wire_packer(mtype, header=header).pack


def _encode_rows(mtype: MsgType, columns: Mapping, header: tuple | None, rows: int) -> list[bytes]:
    """encode_batch for a few rows: one ``struct.pack`` per row, the same checks and errors."""
    layout, float_at, take_floats, pack = _row_plan(mtype, header is not None)
    cols = [value.tolist() if type(value) is np.ndarray and value.shape == (rows,) else _as_list(value, rows)
            for value in (columns[f.name] for f in layout)]
    heads = [_as_list(h, rows) for h in header] if header is not None else []
    type_word = int(mtype)
    out = []
    for r, values in enumerate(zip(*cols)):
        if not math.isfinite(sum(take_floats(values))):
            j = next(j for j in float_at if not math.isfinite(values[j]))
            raise WireError("nonfinite", f"{mtype.name}.{layout[j].name} = {values[j]!r} (row {r})")
        prefix = [h[r] for h in heads]
        if any(not 0 <= v <= UINT32_MAX for v in prefix):
            raise WireError("range", f"header {prefix} (row {r}) is not unsigned 32-bit")
        try:
            out.append(pack(*prefix, type_word, *values))
        except (struct.error, OverflowError) as exc:
            raise WireError("range", f"{mtype.name} row {r}: {exc}") from None
    return out
