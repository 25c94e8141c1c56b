"""Batch codec (sdvisc.wire_batch) against the per-datagram codec: same bytes, same checks."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest

from sdvisc import wire
from sdvisc.wire_batch import decode_batch, encode_batch, float_rows, is_type

CTRL_FLOATS = ("v_ref_d", "v_ref_q", "i_ref_d", "i_ref_q", "delta", "omega", "e_mag")
MEAS_FLOATS = ("t_sim", "v_d", "v_q", "i_d", "i_q", "p", "q", "v_dc", "omega_meas")


def _ctrl_columns(rng, n):
    cols = {k: rng.normal(size=n) for k in CTRL_FLOATS}
    cols.update(wt=np.arange(101, 101 + n), seq=np.arange(n) * 7, meas_seq=np.arange(n) + 3, flags=np.arange(n) % 4)
    return cols


@pytest.mark.parametrize("rows", [3, 9])  # the struct path (small batches) and the numpy path
@pytest.mark.parametrize("header", [True, False])
def test_encode_batch_gives_the_bytes_of_encode(header, rows):
    rng = np.random.default_rng(3)
    cols = _ctrl_columns(rng, rows)
    hdr = (np.arange(rows) + 1, 1_700_000_000, np.arange(rows) * 1000) if header else None
    got = encode_batch(wire.MsgType.CTRL, cols, header=hdr)
    for j, data in enumerate(got):
        values = {k: (int(v[j]) if k in ("wt", "seq", "meas_seq", "flags") else float(v[j])) for k, v in cols.items()}
        h = wire.Header(j + 1, 1_700_000_000, j * 1000) if header else None
        assert data == wire.encode(wire.MsgType.CTRL, values, header=h)


@pytest.mark.parametrize("rows", [4, 12])
def test_encode_batch_refuses_nonfinite_out_of_range_and_missing_fields(rows):
    rng = np.random.default_rng(4)
    cols = _ctrl_columns(rng, rows)
    cols["delta"][2] = math.nan
    with pytest.raises(wire.WireError) as err:
        encode_batch(wire.MsgType.CTRL, cols)
    assert err.value.reason == "nonfinite" and "delta" in str(err.value) and "row 2" in str(err.value)
    cols = _ctrl_columns(rng, rows)
    cols["omega"][1] = 1e39
    with pytest.raises(wire.WireError) as err:
        encode_batch(wire.MsgType.CTRL, cols)
    assert err.value.reason == "range"
    cols = _ctrl_columns(rng, rows)
    cols["seq"][0] = 2**31
    with pytest.raises(wire.WireError):
        encode_batch(wire.MsgType.CTRL, cols)
    cols = _ctrl_columns(rng, rows)
    del cols["flags"]
    with pytest.raises(wire.WireError) as err:
        encode_batch(wire.MsgType.CTRL, cols)
    assert err.value.reason == "field"
    with pytest.raises(wire.WireError):
        encode_batch(wire.MsgType.CTRL, _ctrl_columns(rng, rows), header=(-1, 0, 0))


def _meas(j, seq):
    return {"wt": 101 + j, "seq": seq, **{k: 0.1 * j + 0.01 * i for i, k in enumerate(MEAS_FLOATS)}}


def test_decode_batch_equals_decode_and_rejects_what_decode_rejects():
    good = [wire.encode(wire.MsgType.MEAS, _meas(j, 10 + j), header=wire.Header(j, 5, 6)) for j in range(5)]
    nan = bytearray(good[1])
    struct.pack_into(">f", nan, 4 * (3 + 5), math.nan)  # v_d := NaN
    inf = bytearray(good[2])
    struct.pack_into(">f", inf, 4 * (3 + 11), math.inf)  # omega_meas := Inf
    wrong_type = wire.encode(wire.MsgType.AK, {"wt": 1, "seq": 1, "ak": 1, "ctrl_rx": 1, "ctrl_age_ms": 0.0},
                             header=wire.Header(0, 0, 0))
    same_size_wrong_type = bytearray(good[3])
    struct.pack_into(">i", same_size_wrong_type, 12, int(wire.MsgType.CTRL))
    batch = [good[0], bytes(nan), bytes(inf), wrong_type, good[3], bytes(same_size_wrong_type), good[4][:-4], good[4]]
    stats = wire.DecodeStats()
    rec, index = decode_batch(batch, wire.MsgType.MEAS, header=True, stats=stats)
    assert index.tolist() == [0, 4, 7]
    for r, i in zip(rec, index):
        ref = wire.decode(batch[i], header=True)
        assert (r["hdr_seq"], r["hdr_sec"], r["hdr_nsec"]) == (ref.header.seq, ref.header.sec, ref.header.nsec)
        for k in ("wt", "seq", *MEAS_FLOATS):
            assert r[k] == ref[k]
    assert (stats.ok, stats.nonfinite, stats.length, stats.type) == (3, 2, 2, 1)
    for bad in (bytes(nan), bytes(inf), good[4][:-4]):
        with pytest.raises(wire.WireError):
            wire.decode(bad, header=True)
    assert wire.decode(bytes(same_size_wrong_type), header=True).type == wire.MsgType.CTRL  # valid, not a MEAS
    assert is_type(good[0], wire.MsgType.MEAS, True) and not is_type(bytes(same_size_wrong_type), wire.MsgType.MEAS, True)
    assert not is_type(wrong_type, wire.MsgType.MEAS, True)


def test_decode_batch_of_nothing():
    rec, index = decode_batch([], wire.MsgType.MEAS, header=False)
    assert len(rec) == 0 and len(index) == 0


@pytest.mark.parametrize("header", [True, False])
def test_float_rows_equals_the_fields_of_the_records(header):
    batch = [wire.encode(wire.MsgType.MEAS, _meas(j, 10 + j), header=wire.Header(j, 5, 6) if header else None)
             for j in range(4)]
    rec, _ = decode_batch(batch, wire.MsgType.MEAS, header=header)
    for records in (rec, rec[[2, 0]], rec[::2]):  # a view of the received bytes, a copy, a strided view
        rows = float_rows(records, MEAS_FLOATS)
        assert rows.dtype == np.float64 and rows.shape == (len(MEAS_FLOATS), len(records))
        for i, k in enumerate(MEAS_FLOATS):
            assert rows[i].tolist() == records[k].astype(float).tolist()
    assert float_rows(rec, ("seq", "t_sim")).tolist() == [rec["seq"].tolist(), rec["t_sim"].astype(float).tolist()]


def test_decode_batch_small_and_large_batches_accept_and_count_alike():
    """A few datagrams are checked one struct.unpack each, many with numpy: the same verdicts."""
    rng = np.random.default_rng(7)
    batch = []
    for j in range(40):
        data = bytearray(wire.encode(wire.MsgType.MEAS, _meas(j % 9, j), header=wire.Header(j, 5, 6)))
        kind = rng.integers(6)
        if kind == 1:
            struct.pack_into(">f", data, 4 * (3 + 4 + rng.integers(8)), [math.nan, math.inf, -math.inf][j % 3])
        elif kind == 2:
            struct.pack_into(">i", data, 12, int(wire.MsgType.CTRL))
        elif kind == 3:
            data = data[:-4]
        batch.append(bytes(data))
    large_stats, small_stats = wire.DecodeStats(), wire.DecodeStats()
    rec, index = decode_batch(batch, wire.MsgType.MEAS, header=True, stats=large_stats)
    pieces = [decode_batch(batch[k:k + 3], wire.MsgType.MEAS, header=True, stats=small_stats)
              for k in range(0, len(batch), 3)]
    assert small_stats.as_dict() == large_stats.as_dict() and large_stats.nonfinite and large_stats.type
    assert [3 * k + i for k, (_, idx) in enumerate(pieces) for i in idx.tolist()] == index.tolist()
    assert b"".join(r.tobytes() for r, _ in pieces) == rec.tobytes()
    requests = [wire.encode(wire.MsgType.REQUEST, {"req_id": 1, "cmd": 1, "wt": 101, "sdc_ip": 0, "mask": 0, "h": 0.0,
                                                   "d": 0.0, "m_q": 0.0, "v_ref": 0.0, "q_ref": 0.0, "supp": 0})]
    bad_cmd = bytearray(requests[0])
    struct.pack_into(">i", bad_cmd, 8, 99)  # cmd: no such command
    for many in (False, True):
        stats = wire.DecodeStats()
        got, idx = decode_batch((requests + [bytes(bad_cmd)]) * (6 if many else 1), wire.MsgType.REQUEST,
                                header=False, stats=stats)
        assert stats.range == len(idx) and len(got) == len(idx) == (6 if many else 1)
