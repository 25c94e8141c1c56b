"""Unit tests of sdvisc.wire: round trips, byte order, strict rejections and helpers."""

from __future__ import annotations

import math
import re
import struct
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from sdvisc import wire
from sdvisc.wire import (
    LAYOUTS,
    MAX_WORDS,
    Command,
    DecodeStats,
    Header,
    Message,
    MsgType,
    Status,
    WireError,
    decode,
    encode,
    i32_to_ip,
    ip_to_i32,
    parse_turbine,
    turbine_id,
    turbine_name,
)

DOCS = Path(__file__).resolve().parents[2] / "docs" / "wire-format.md"

int32s = st.integers(min_value=wire.INT32_MIN, max_value=wire.INT32_MAX)
uint32s = st.integers(min_value=0, max_value=wire.UINT32_MAX)
float32s = st.floats(width=32, allow_nan=False, allow_infinity=False)
headers = st.builds(Header, seq=uint32s, sec=uint32s, nsec=uint32s)


def value_strategy(field: wire.Field) -> st.SearchStrategy[int | float]:
    if field.kind == "f32":
        return float32s
    if field.enum is not None:
        return st.sampled_from([int(m) for m in field.enum])
    return int32s


def values_strategy(mtype: MsgType) -> st.SearchStrategy[dict[str, int | float]]:
    return st.fixed_dictionaries({f.name: value_strategy(f) for f in LAYOUTS[mtype][1:]})


messages = st.sampled_from(list(MsgType)).flatmap(
    lambda mtype: st.tuples(st.just(mtype), values_strategy(mtype))
)


def sample_values(mtype: MsgType) -> dict[str, int | float]:
    """A valid set of values: 1 for enum fields, index-derived numbers otherwise."""
    values: dict[str, int | float] = {}
    for index, field in enumerate(LAYOUTS[mtype][1:], start=1):
        if field.enum is not None:
            values[field.name] = int(next(iter(field.enum)))
        elif field.kind == "f32":
            values[field.name] = index * 0.25
        else:
            values[field.name] = index
    return values


def meas_bytes(header: bool = True, **overrides: float) -> bytes:
    values = sample_values(MsgType.MEAS) | overrides
    return encode(MsgType.MEAS, values, header=Header(1, 2, 3) if header else None)


# --- round trips -------------------------------------------------------------------------------


@given(messages, headers)
def test_round_trip_with_header(message: tuple[MsgType, dict], header: Header) -> None:
    mtype, values = message
    data = encode(mtype, values, header=header)
    assert len(data) == 4 * (len(LAYOUTS[mtype]) + 3)
    decoded = decode(data, header=True)
    assert decoded == Message(mtype, values, header)


@given(messages)
def test_round_trip_without_header(message: tuple[MsgType, dict]) -> None:
    mtype, values = message
    decoded = decode(encode(mtype, values), header=False)
    assert decoded.type is mtype
    assert decoded.header is None
    assert decoded.values == values
    for field in LAYOUTS[mtype][1:]:
        expected_type = float if field.kind == "f32" else int
        assert type(decoded[field.name]) is expected_type


def test_message_getitem_and_reencode() -> None:
    message = decode(meas_bytes(), header=True)
    assert message["msg_type"] == MsgType.MEAS
    assert message["wt"] == message.values["wt"]
    with pytest.raises(KeyError):
        message["nope"]
    assert message.encode() == meas_bytes()


def test_float_values_take_float32_precision() -> None:
    message = decode(meas_bytes(t_sim=0.1), header=True)
    assert message["t_sim"] == struct.unpack(">f", struct.pack(">f", 0.1))[0]
    assert message["t_sim"] != 0.1


def test_encode_accepts_consistent_msg_type_key() -> None:
    values = sample_values(MsgType.AK)
    assert encode(MsgType.AK, {"msg_type": 3, **values}) == encode(MsgType.AK, values)


# --- byte order and header ---------------------------------------------------------------------


def test_big_endian_hand_built_example() -> None:
    values = {"req_id": 7, "status": Status.NO_PATH, "wt": 101, "cmd": Command.TAKEOVER, "detail": -1}
    expected = struct.pack(">i", 5) + struct.pack(">iiiii", 7, 3, 101, 4, -1)
    assert encode(MsgType.REPLY, values) == expected
    assert expected[:4] == b"\x00\x00\x00\x05"


def test_float_words_are_big_endian_ieee754() -> None:
    values = {"sdc_id": 1, "seq": 2, "n_instances": 3, "t_wall": 1.5}
    data = encode(MsgType.HEARTBEAT, values)
    assert data[-4:] == bytes.fromhex("3fc00000")


def test_header_words_come_first_and_decode() -> None:
    data = meas_bytes(header=True)
    assert data[:12] == struct.pack(">III", 1, 2, 3)
    assert data[12:16] == struct.pack(">i", int(MsgType.MEAS))
    assert decode(data, header=True).header == Header(seq=1, sec=2, nsec=3)
    assert data[12:] == meas_bytes(header=False)


def test_header_now_uses_wall_clock() -> None:
    header = Header.now(42)
    assert header.seq == 42
    assert 0 <= header.nsec < 1_000_000_000
    assert header.sec > 1_600_000_000
    assert Header.now(2**32 + 5).seq == 5


# --- decode rejections -------------------------------------------------------------------------


def reason_of(data: bytes, *, header: bool = True) -> str:
    with pytest.raises(WireError) as caught:
        decode(data, header=header)
    return caught.value.reason


LENGTH_CASES = {
    "empty": b"",
    "header only": struct.pack(">III", 1, 2, 3),
    "not a multiple of 4": meas_bytes()[:-1],
    "one word short": meas_bytes()[:-4],
    "one word long": meas_bytes() + b"\x00" * 4,
    "over 300 words": meas_bytes() + b"\x00" * 4 * MAX_WORDS,
}


@pytest.mark.parametrize("data", LENGTH_CASES.values(), ids=LENGTH_CASES.keys())
def test_rejects_wrong_length(data: bytes) -> None:
    assert reason_of(data) == "length"


def test_rejects_more_than_max_words_even_without_header() -> None:
    assert reason_of(b"\x00\x00\x00\x01" * (MAX_WORDS + 1), header=False) == "length"


def test_header_mismatch_is_a_length_or_type_error() -> None:
    assert reason_of(meas_bytes(header=False), header=True) in {"length", "type"}
    assert reason_of(meas_bytes(header=True), header=False) in {"length", "type"}


@pytest.mark.parametrize("type_word", [0, 7, -1, 2**31 - 1])
def test_rejects_unknown_type(type_word: int) -> None:
    data = bytearray(meas_bytes())
    data[12:16] = struct.pack(">i", type_word)
    assert reason_of(bytes(data)) == "type"


MEAS_FLOATS = [f.name for f in LAYOUTS[MsgType.MEAS] if f.kind == "f32"]


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf], ids=["nan", "+inf", "-inf"])
@pytest.mark.parametrize("name", MEAS_FLOATS)
def test_rejects_nonfinite_float(name: str, bad: float) -> None:
    names = [f.name for f in LAYOUTS[MsgType.MEAS]]
    data = bytearray(meas_bytes())
    offset = 12 + 4 * names.index(name)
    data[offset:offset + 4] = struct.pack(">f", bad)
    assert reason_of(bytes(data)) == "nonfinite"


ENUM_CASES = [
    (MsgType.REQUEST, "cmd", 0),
    (MsgType.REQUEST, "cmd", 9),
    (MsgType.REPLY, "status", -1),
    (MsgType.REPLY, "status", 8),
    (MsgType.REPLY, "cmd", 99),
]


@pytest.mark.parametrize(("mtype", "name", "code"), ENUM_CASES)
def test_rejects_enum_out_of_range(mtype: MsgType, name: str, code: int) -> None:
    names = [f.name for f in LAYOUTS[mtype]]
    data = bytearray(encode(mtype, sample_values(mtype)))
    offset = 4 * names.index(name)
    data[offset:offset + 4] = struct.pack(">i", code)
    assert reason_of(bytes(data), header=False) == "range"


# --- encode rejections -------------------------------------------------------------------------


def encode_reason(mtype: MsgType, values: dict, header: Header | None = None) -> str:
    with pytest.raises(WireError) as caught:
        encode(mtype, values, header=header)
    return caught.value.reason


def without(values: dict, name: str) -> dict:
    return {k: v for k, v in values.items() if k != name}


MEAS = sample_values(MsgType.MEAS)
@pytest.mark.parametrize(
    ("values", "reason"),
    [
        (without(MEAS, "p"), "field"),
        (MEAS | {"bogus": 1}, "field"),
        (MEAS | {"msg_type": 2}, "field"),
        (MEAS | {"wt": 1.5}, "field"),
        (MEAS | {"p": "high"}, "field"),
        (MEAS | {"p": math.nan}, "nonfinite"),
        (MEAS | {"q": math.inf}, "nonfinite"),
        (MEAS | {"v_dc": -math.inf}, "nonfinite"),
        (MEAS | {"wt": 2**31}, "range"),
        (MEAS | {"seq": -(2**31) - 1}, "range"),
        (MEAS | {"p": 1e39}, "range"),
    ],
    ids=[
        "missing", "extra", "msg_type mismatch", "float in i32", "string in f32",
        "nan", "+inf", "-inf", "int32 overflow", "int32 underflow", "float32 overflow",
    ],
)
def test_encode_rejects(values: dict, reason: str) -> None:
    assert encode_reason(MsgType.MEAS, values) == reason


def test_encode_rejects_enum_value_not_a_member() -> None:
    values = sample_values(MsgType.REQUEST) | {"cmd": 42}
    assert encode_reason(MsgType.REQUEST, values) == "range"


def test_encode_rejects_unknown_type() -> None:
    assert encode_reason(99, MEAS) == "type"  # type: ignore[arg-type]


def test_encode_rejects_header_out_of_range() -> None:
    assert encode_reason(MsgType.MEAS, MEAS, Header(-1, 0, 0)) == "range"


def test_wire_error_is_a_value_error() -> None:
    with pytest.raises(ValueError, match="length"):
        decode(b"\x00", header=False)


# --- DecodeStats -------------------------------------------------------------------------------


def test_decode_stats_counts_every_reason_without_raising() -> None:
    stats = DecodeStats()
    nan_meas = bytearray(meas_bytes())
    nan_meas[-4:] = struct.pack(">f", math.nan)
    bad_enum = bytearray(encode(MsgType.REPLY, sample_values(MsgType.REPLY), header=Header(0, 0, 0)))
    bad_enum[20:24] = struct.pack(">i", 77)
    datagrams = [
        meas_bytes(),
        meas_bytes(),
        b"\x01\x02\x03",
        struct.pack(">IIIi", 0, 0, 0, 9),
        bytes(nan_meas),
        bytes(bad_enum),
    ]
    results = [stats.decode(data, header=True) for data in datagrams]
    assert [r is not None for r in results] == [True, True, False, False, False, False]
    assert stats.as_dict() == {
        "ok": 2, "length": 1, "type": 1, "nonfinite": 1, "range": 1, "field": 0, "rejected": 4,
    }
    assert stats.rejected == 4


# --- helpers -----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("ip", "word"),
    [("0.0.0.0", 0), ("10.0.0.1", 0x0A000001), ("127.255.255.255", 2**31 - 1),
     ("128.0.0.0", -(2**31)), ("192.168.1.20", 0xC0A80114 - 2**32), ("255.255.255.255", -1)],
)
def test_ip_to_i32(ip: str, word: int) -> None:
    assert ip_to_i32(ip) == word
    assert i32_to_ip(word) == ip


@given(uint32s)
def test_ip_round_trip(address: int) -> None:
    ip = ".".join(str((address >> shift) & 0xFF) for shift in (24, 16, 8, 0))
    word = ip_to_i32(ip)
    assert wire.INT32_MIN <= word <= wire.INT32_MAX
    assert i32_to_ip(word) == ip
    request = sample_values(MsgType.REQUEST) | {"sdc_ip": word}
    assert decode(encode(MsgType.REQUEST, request), header=False)["sdc_ip"] == word


def test_ip_helpers_reject_garbage() -> None:
    with pytest.raises(ValueError):
        ip_to_i32("10.0.0.256")
    with pytest.raises(ValueError):
        i32_to_ip(2**31)


@pytest.mark.parametrize(
    ("name", "cluster", "number", "wid"),
    [("wt1_1", 1, 1, 101), ("wt1_10", 1, 10, 110), ("wt3_7", 3, 7, 307), ("wt12_99", 12, 99, 1299)],
)
def test_turbine_naming(name: str, cluster: int, number: int, wid: int) -> None:
    assert parse_turbine(name) == (cluster, number)
    assert turbine_id(cluster, number) == wid
    assert turbine_name(wid) == name


@pytest.mark.parametrize("name", ["wt1", "wt1_0", "wt0_1", "wt1_100", "WT1_1", "wt1_1 ", "sdc1", "wt_1"])
def test_parse_turbine_rejects(name: str) -> None:
    with pytest.raises(ValueError):
        parse_turbine(name)


def test_turbine_id_rejects_out_of_range() -> None:
    for cluster, number in [(0, 1), (1, 0), (1, 100)]:
        with pytest.raises(ValueError):
            turbine_id(cluster, number)
    with pytest.raises(ValueError):
        turbine_name(100)


# --- layouts and documentation -----------------------------------------------------------------


def test_every_layout_starts_with_msg_type_and_fits() -> None:
    for mtype, layout in LAYOUTS.items():
        assert layout[0].name == "msg_type" and layout[0].kind == "i32"
        assert len({f.name for f in layout}) == len(layout)
        assert wire.word_count(mtype, header=True) <= MAX_WORDS


def test_ports_are_distinct_and_documented() -> None:
    """Every role listens on its own port, and docs/wire-format.md's port table says the same."""
    assert len(set(wire.PORT_ROLES)) == len(wire.PORT_ROLES) == len(set(wire.PORT_ROLES.values()))
    doc = (Path(__file__).resolve().parents[2] / "docs" / "wire-format.md").read_text()
    documented = {int(m.group(2)): m.group(1) for m in re.finditer(r"^\| `(PORT_[A-Z]+)` \| (\d+) \|", doc, re.M)}
    assert documented == {port: f"PORT_{role.upper()}" for port, role in wire.PORT_ROLES.items()}
    assert all(getattr(wire, name) == port for port, name in documented.items())


@pytest.mark.parametrize("mtype", list(MsgType), ids=lambda t: t.name)
def test_docs_table_matches_layout(mtype: MsgType) -> None:
    """docs/wire-format.md lists every word with its index and both byte offsets."""
    text = DOCS.read_text(encoding="utf-8")
    section = text.split(f"### {mtype.name} ", 1)[1].split("\n### ", 1)[0]
    rows = re.findall(r"^\| (\d+) \| (\d+) \| (\d+) \| `(\w+)` \| (i32|f32) \|", section, re.MULTILINE)
    expected = [(str(i), str(12 + 4 * i), str(4 * i), f.name, f.kind) for i, f in enumerate(LAYOUTS[mtype])]
    assert rows == expected
