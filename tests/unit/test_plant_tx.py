"""The plant's MEAS packer (plant.service.endpoint_tx) against the general encoder, sdvisc.wire.encode: the
same bytes where the encoder accepts the values, None (counted by the service, never sent) where it
refuses them."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from plant.service.endpoint_tx import MeasPacker
from sdvisc import wire
from sdvisc.vocabulary import MEAS_FIELDS

values = st.lists(st.one_of(st.floats(-2.0, 2.0), st.floats(allow_nan=True, allow_infinity=True)),
                  min_size=len(MEAS_FIELDS), max_size=len(MEAS_FIELDS))


def reference(header: bool, wid: int, seq: int, t_sim: float, vals, sec: int, nsec: int) -> bytes | None:
    fields = {"wt": wid, "seq": seq, "t_sim": t_sim, **dict(zip(MEAS_FIELDS, vals))}
    try:
        return wire.encode(wire.MsgType.MEAS, fields, header=wire.Header(seq, sec, nsec) if header else None)
    except wire.WireError:
        return None


@pytest.mark.parametrize("header", [True, False])
@given(vals=values, seq=st.integers(0, 2**31 - 1), t_sim=st.floats(0.0, 1e6), sec=st.integers(0, 2**32 - 1),
       nsec=st.integers(0, 999_999_999), wid=st.sampled_from([101, 510, 4999]))
def test_the_packer_writes_what_wire_encode_writes_or_refuses_what_it_refuses(header, vals, seq, t_sim, sec, nsec, wid):
    got = MeasPacker(header).pack(wid, seq, t_sim, vals, sec, nsec)
    assert got == reference(header, wid, seq, t_sim, vals, sec, nsec)


def test_a_diverged_model_value_is_refused_not_raised():
    packer = MeasPacker(True)
    good = [1.0] * len(MEAS_FIELDS)
    assert packer.pack(101, 1, 0.0, good, 0, 0) is not None
    for bad in (float("nan"), float("inf"), -float("inf"), 1e39):
        assert packer.pack(101, 1, 0.0, [bad] + good[1:], 0, 0) is None
    assert packer.pack(101, 2**31, 0.0, good, 0, 0) is None  # seq beyond int32
