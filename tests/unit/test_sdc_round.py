"""The SDC round without a socket (sdc_unit.round): MEAS records in, CTRL values and datagrams out."""

from __future__ import annotations

import numpy as np
import pytest

from sdc_unit.bank import ControllerBank
from sdc_unit.round import FLAG_BACKUP, pack_ctrl, step_round
from sdvisc import wire
from sdvisc.vocabulary import CTRL_OUTPUTS
from sdvisc.wire_batch import decode_batch

TS = 0.67e-3


def _records(wts, seq, v_d=1.0):
    packets = [wire.encode(wire.MsgType.MEAS, {"wt": w, "seq": seq, "t_sim": seq * TS, "v_d": v_d, "v_q": 0.05,
                                                "i_d": 0.5, "i_q": -0.1, "p": 0.5, "q": 0.1, "v_dc": 1.0,
                                                "omega_meas": 1.0}, header=wire.Header(seq, 0, 0))
               for w in wts]
    rec, _ = decode_batch(packets, wire.MsgType.MEAS, header=True)
    return rec


def test_a_round_answers_started_slots_with_their_outputs():
    bank = ControllerBank(capacity=4, step_s=TS)
    for slot in (0, 1):
        bank.start(slot, {"mask": 0})
    slots = np.array([0, 1, 2])  # slot 2 never started: no answer
    rec = _records([101, 102, 103], seq=7)
    valid, ctrl = step_round(bank, slots, rec, backup=True)
    assert valid.tolist() == [True, True, False]
    assert ctrl["wt"].tolist() == [101, 102] and ctrl["meas_seq"].tolist() == [7, 7]
    assert (ctrl["flags"] & FLAG_BACKUP).all()
    # bumpless start: the first output continues the converter voltage v + (r_f + j x_f) i (one step moves it ~1e-5)
    assert ctrl["v_ref_d"] == pytest.approx(1.0 + 0.003 * 0.5 + 0.08 * 0.1, abs=1e-4)
    packets = pack_ctrl(ctrl, np.array([1, 2]), now=12.5)
    msgs = [wire.decode(p, header=True) for p in packets]
    assert [m["seq"] for m in msgs] == [1, 2] and [m["wt"] for m in msgs] == [101, 102]
    for m, r in zip(msgs, range(2)):
        for k in CTRL_OUTPUTS:
            assert m[k] == pytest.approx(ctrl[k][r], rel=1e-6)


def test_a_value_beyond_float32_loses_only_its_own_datagram():
    ctrl = {k: np.array([0.5, 0.5, 0.5]) for k in CTRL_OUTPUTS}
    ctrl["e_mag"] = np.array([1.0, 1e39, 1.0])
    ctrl.update(wt=np.array([101, 102, 103]), meas_seq=np.array([1, 1, 1]), flags=np.zeros(3, dtype=int))
    packets = pack_ctrl(ctrl, np.array([4, 5, 6]), now=None)
    assert packets[1] is None
    assert [wire.decode(p, header=False)["wt"] for p in (packets[0], packets[2])] == [101, 103]
