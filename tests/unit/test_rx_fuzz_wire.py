"""Property-based fuzzing of the receive side of the wire codec (issue 13).

For any datagram — random bytes, real messages of every type truncated, extended or with flipped
bits, words replaced by extreme patterns (INT32_MIN/MAX, NaN/Inf bit patterns, float32 max,
subnormals) — :func:`sdvisc.wire.decode` either returns a message that re-encodes to exactly the
same bytes and whose floats are finite and enums valid, or raises :class:`~sdvisc.wire.WireError`
with a known reason; :meth:`~sdvisc.wire.DecodeStats.decode` returns the same message or None
with exactly one reason counted; :func:`sdvisc.wire_batch.decode_batch` accepts exactly the
datagrams ``decode`` accepts as that type, with the same values, and counts the others.
"""

from __future__ import annotations

import math
import struct

import numpy as np
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from sdvisc import wire
from sdvisc.wire import LAYOUTS, REJECT_REASONS, DecodeStats, Header, Message, MsgType, WireError
from sdvisc.wire_batch import decode_batch, is_type

FUZZ = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])

EXTREME_WORDS = (
    0x80000000,  # INT32_MIN; also float -0.0
    0x7FFFFFFF,  # INT32_MAX; also a NaN
    0x00000000, 0xFFFFFFFF,  # 0 and -1 (-1 is a NaN as a float)
    0x7FC00000, 0xFFC00000, 0x7F800001, 0x7FBFFFFF,  # quiet/signalling NaNs of both signs
    0x7F800000, 0xFF800000,  # +Inf, -Inf
    0x7F7FFFFF, 0xFF7FFFFF,  # +-float32 max
    0x00000001, 0x807FFFFF,  # subnormals
    0x3F800000,  # 1.0
    *range(0, 10),  # every msg_type, enum and Status code nearby
)
extreme_words = st.sampled_from(EXTREME_WORDS)
words = st.one_of(extreme_words, st.integers(0, wire.UINT32_MAX))
int32s = st.integers(wire.INT32_MIN, wire.INT32_MAX)
float32s = st.floats(width=32, allow_nan=False, allow_infinity=False)
uint32s = st.integers(0, wire.UINT32_MAX)


def pack_words(ws: list[int]) -> bytes:
    return struct.pack(f">{len(ws)}I", *ws)


def value_strategy(field: wire.Field) -> st.SearchStrategy:
    if field.enum is not None:
        return st.sampled_from([int(m) for m in field.enum])
    return float32s if field.kind == "f32" else int32s


@st.composite
def real_messages(draw, mtype=None) -> tuple[bytes, bool]:
    """A valid encoded message of any (or the given) type, with or without the header."""
    mtype = draw(st.sampled_from(list(MsgType))) if mtype is None else mtype
    has_header = draw(st.booleans())
    values = draw(st.fixed_dictionaries({f.name: value_strategy(f) for f in LAYOUTS[mtype][1:]}))
    header = draw(st.builds(Header, uint32s, uint32s, uint32s)) if has_header else None
    return wire.encode(mtype, values, header=header), has_header


@st.composite
def mutated(draw, mtype=None) -> tuple[bytes, bool]:
    """A real message, then one or more of: truncated, extended, bits flipped, words replaced by
    extreme patterns; or decoded with the wrong header setting."""
    data, has_header = draw(real_messages(mtype))
    buf = bytearray(data)
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(("truncate", "extend", "flip", "word", "word", "header")))
        if kind == "truncate" and buf:
            del buf[draw(st.integers(0, len(buf) - 1)):]
        elif kind == "extend":
            buf += draw(st.one_of(st.binary(min_size=1, max_size=16),
                                  st.lists(extreme_words, min_size=1, max_size=4).map(pack_words)))
        elif kind == "flip" and buf:
            for _ in range(draw(st.integers(1, 4))):
                bit = draw(st.integers(0, 8 * len(buf) - 1))
                buf[bit // 8] ^= 1 << (bit % 8)
        elif kind == "word" and len(buf) >= 4:
            at = 4 * draw(st.integers(0, len(buf) // 4 - 1))
            buf[at:at + 4] = struct.pack(">I", draw(extreme_words))
        elif kind == "header":
            has_header = not has_header
    return bytes(buf), has_header


@st.composite
def word_messages(draw) -> tuple[bytes, bool]:
    """Datagrams of (nearly) the right length for a type, every word extreme or random."""
    mtype = draw(st.sampled_from(list(MsgType)))
    has_header = draw(st.booleans())
    n = wire.word_count(mtype, header=has_header) + draw(st.sampled_from((0, 0, 0, -1, 1)))
    ws = draw(st.lists(words, min_size=n, max_size=n))
    at = 3 if has_header else 0
    if n > at and draw(st.integers(0, 4)):  # mostly the real type word, so later checks are reached
        ws[at] = int(mtype)
    return pack_words(ws), has_header


random_datagrams = st.tuples(st.binary(max_size=1300), st.booleans())
any_datagram = st.one_of(random_datagrams, mutated(), word_messages(), real_messages())


def decode_outcome(data: bytes, has_header: bool) -> Message | str:
    """The message decode returns (checked for validity) or the reason it rejects; any other
    exception fails the test."""
    try:
        msg = wire.decode(data, header=has_header)
    except WireError as error:
        assert error.reason in REJECT_REASONS
        assert error.reason != "field"  # decoding never finds a "field" error (encoding only)
        return error.reason
    assert isinstance(msg.type, MsgType)
    layout = LAYOUTS[msg.type]
    assert set(msg.values) == {f.name for f in layout[1:]}
    for f in layout[1:]:
        value = msg[f.name]
        if f.kind == "f32":
            assert type(value) is float and math.isfinite(value) and abs(value) <= wire.FLOAT32_MAX
        else:
            assert type(value) is int and wire.INT32_MIN <= value <= wire.INT32_MAX
            if f.enum is not None:
                f.enum(value)  # a valid member, never raises
    if has_header:
        assert msg.header is not None
        assert all(0 <= getattr(msg.header, k) <= wire.UINT32_MAX for k in ("seq", "sec", "nsec"))
    else:
        assert msg.header is None
    assert msg.encode() == data  # nothing lost or altered: an accepted datagram is exactly a message
    return msg


@FUZZ
@given(any_datagram)
def test_decode_returns_a_valid_message_or_raises_wire_error(datagram):
    outcome = decode_outcome(*datagram)
    event(outcome if isinstance(outcome, str) else f"accepted {outcome.type.name}")


@FUZZ
@given(any_datagram)
def test_decode_stats_counts_exactly_one_outcome(datagram):
    data, has_header = datagram
    outcome = decode_outcome(data, has_header)
    stats = DecodeStats()
    result = stats.decode(data, header=has_header)
    counts = stats.as_dict()
    if isinstance(outcome, str):
        assert result is None
        assert counts["rejected"] == 1 and counts[outcome] == 1 and counts["ok"] == 0
    else:
        assert result == outcome
        assert counts["ok"] == 1 and counts["rejected"] == 0
    assert sum(counts[k] for k in ("ok", *REJECT_REASONS)) == 1


batch_cases = st.sampled_from(list(MsgType)).flatmap(
    lambda m: st.tuples(st.just(m), st.booleans(),
                        st.lists(st.one_of(real_messages(m), mutated(m), word_messages(), random_datagrams),
                                 max_size=12)))
"""(type, header setting, datagrams): mostly of that type, some of others, some garbage."""


def _expected_batch_reason(data: bytes, mtype: MsgType, has_header: bool, outcome) -> str:
    """Which counter decode_batch uses for a datagram it does not accept as ``mtype``."""
    size = 4 * wire.word_count(mtype, header=has_header)
    if len(data) != size:
        return "length"
    at = 12 if has_header else 0
    if struct.unpack_from(">i", data, at)[0] != int(mtype):
        return "type"
    assert isinstance(outcome, str)  # right size and type word, so decode rejected it on its values
    return outcome


@FUZZ
@given(batch_cases)
def test_decode_batch_accepts_exactly_what_decode_accepts(case):
    mtype, has_header, datagrams = case
    # each datagram is decoded with the batch's header setting
    datagrams = [d for d, _ in datagrams]
    outcomes = [decode_outcome(d, has_header) for d in datagrams]
    accepted = [i for i, o in enumerate(outcomes) if isinstance(o, Message) and o.type == mtype]
    stats = DecodeStats()
    records, index = decode_batch(datagrams, mtype, header=has_header, stats=stats)
    assert index.tolist() == accepted
    assert len(records) == len(accepted)
    for row, i in enumerate(accepted):
        msg = outcomes[i]
        assert is_type(datagrams[i], mtype, has_header)
        for name, value in msg.values.items():
            got = records[name][row].item()
            assert got == value and type(got) is type(value), (name, got, value)
        assert records["msg_type"][row] == int(mtype)
        if has_header:
            assert (records["hdr_seq"][row], records["hdr_sec"][row], records["hdr_nsec"][row]) == \
                (msg.header.seq, msg.header.sec, msg.header.nsec)
    expected = dict.fromkeys(("ok", *REJECT_REASONS), 0)
    expected["ok"] = len(accepted)
    for i, (d, o) in enumerate(zip(datagrams, outcomes)):
        if i not in accepted:
            expected[_expected_batch_reason(d, mtype, has_header, o)] += 1
    counts = stats.as_dict()
    assert {k: counts[k] for k in expected} == expected
    assert counts["rejected"] == len(datagrams) - len(accepted)


@FUZZ
@given(st.sampled_from(list(MsgType)), st.booleans(), st.lists(st.binary(max_size=80), max_size=10))
def test_decode_batch_without_stats_never_raises(mtype, has_header, datagrams):
    records, index = decode_batch(datagrams, mtype, header=has_header)
    assert len(records) == len(index) and all(0 <= i < len(datagrams) for i in index.tolist())


def test_every_extreme_float_word_in_every_float_field_is_rejected_or_finite():
    """Deterministic sweep: each extreme pattern in each f32 word of every type, both header settings."""
    for mtype in MsgType:
        for has_header in (False, True):
            base = wire.encode(mtype, {f.name: (int(next(iter(f.enum))) if f.enum else 0)
                                       for f in LAYOUTS[mtype][1:]},
                               header=Header(1, 2, 3) if has_header else None)
            first = 3 if has_header else 0
            for j, f in enumerate(LAYOUTS[mtype]):
                for word in EXTREME_WORDS:
                    data = bytearray(base)
                    data[4 * (first + j):4 * (first + j) + 4] = struct.pack(">I", word)
                    outcome = decode_outcome(bytes(data), has_header)
                    if f.kind == "f32":
                        bits_nonfinite = (word & 0x7F800000) == 0x7F800000
                        assert (outcome == "nonfinite") == bits_nonfinite, (mtype, f.name, hex(word))
                    records, index = decode_batch([bytes(data)], mtype, header=has_header)
                    assert (len(index) == 1) == (isinstance(outcome, Message) and outcome.type == mtype)
                    for g in LAYOUTS[mtype]:
                        if g.kind == "f32":
                            assert np.isfinite(records[g.name]).all()
