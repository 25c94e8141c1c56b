"""The SDC's compiled stepping (sdc_unit.ctrl_jit via ControllerBank.answer_datagrams) against its
reference, the numpy rounds (sdc_unit.round.answer_rows: step_round, pack_ctrl): the same CTRL bytes
and the same counts for the same datagrams, good and bad, one per wake-up or several. The datagrams
go through the service's one admission path (sdc_unit.core) and what it sends is recorded (the
socket calls are test_sdc_gather.py's and test_sdc_service_udp.py's); the reference is the same
service with the compiled stepping switched off."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sdc_unit.answer import ctrl_bytes
from sdc_unit.bank import ControllerBank
from sdc_unit.round import pack_ctrl, step_round
from sdc_unit.service import SdcService
from sdvisc import wire
from sdvisc.config import SdcConfig
from sdvisc.vocabulary import MEAS_FIELDS
from sdvisc.wire_batch import decode_batch, is_type
from tests.unit.test_sdc_admission import CONTROLLER, TS, request

TURBINES = (101, 102, 205)


def meas(wt: int, seq: int, k: float, t_sim: float | None = None, header: bool = True, **changes) -> bytes:
    """A MEAS whose values move with ``k`` (the controller's states and limiter do something)."""
    values = {"wt": wt, "seq": seq, "t_sim": seq * TS if t_sim is None else t_sim, "v_d": 1.0 + 0.02 * math.sin(k / 40),
              "v_q": 0.05 * math.cos(k / 17), "i_d": 0.5 + 0.4 * math.sin(k / 90), "i_q": -0.1, "p": 0.5,
              "q": 0.1 * math.sin(k / 33), "v_dc": 1.0, "omega_meas": 1.0 + 1e-3 * math.sin(k / 60)}
    values.update(changes)
    return wire.encode(wire.MsgType.MEAS, values, header=wire.Header(seq, 7, 1000 * (seq % 10**6)) if header else None)


class Sink:
    """What the services send, in order."""

    def __init__(self) -> None:
        self.sent: list[tuple[bytes, tuple]] = []

    def sendto(self, data, addr) -> int:
        self.sent.append((bytes(data), addr))
        return len(data)


def make(tmp_path, compiled: bool, dtype: str = "float64", role: str = "primary",
         header: bool = True) -> tuple[SdcService, Sink]:
    sink = Sink()
    cfg = SdcConfig(step_s=TS, controller_vip=CONTROLLER[0], capacity=8, out_dir=str(tmp_path), dtype=dtype,
                    role=role, header=header, gather_steps=0.0)
    svc = SdcService(cfg, sock=sink)
    svc.bank.compiled_answers = compiled and svc.bank.compiled_answers
    return svc, sink


def run_both(tmp_path, rounds: list[list[bytes]], **kwargs) -> tuple[SdcService, Sink, SdcService, Sink]:
    fast, fast_sink = make(tmp_path, True, **kwargs)
    ref, ref_sink = make(tmp_path, False, **kwargs)
    assert fast.bank.compiled_answers and not ref.bank.compiled_answers
    for k, datagrams in enumerate(rounds):
        now = 100.0 + k * TS
        for svc in (fast, ref):
            pairs = [(d, CONTROLLER if is_type(d, wire.MsgType.REQUEST, svc.core.header) else ("127.0.0.1", 40000))
                     for d in datagrams]
            svc.serve(pairs, now)
    return fast, fast_sink, ref, ref_sink


def start_all(header: bool = True) -> list[bytes]:
    return [command(wire.Command.START_INSTANCE, wt, i + 1, header) for i, wt in enumerate(TURBINES)]


def command(cmd: wire.Command, wt: int, req_id: int, header: bool = True) -> bytes:
    values = wire.decode(request(cmd, wt, req_id=req_id), header=True).values
    return wire.encode(wire.MsgType.REQUEST, values, header=wire.Header(req_id, 0, 0) if header else None)


def with_nan(data: bytes) -> bytes:
    """``data`` (a MEAS with header) with v_d = NaN, as a faulty sender would send it."""
    return data[:28] + bytes.fromhex("7fc00000") + data[32:]


def assert_same(fast: SdcService, fast_sink: Sink, ref: SdcService, ref_sink: Sink) -> None:
    assert [a for _, a in fast_sink.sent] == [a for _, a in ref_sink.sent]
    assert [d for d, _ in fast_sink.sent] == [d for d, _ in ref_sink.sent]
    assert fast.rejected == ref.rejected
    assert fast.rx_stats.as_dict() == ref.rx_stats.as_dict()
    for wid, inst in fast.instances.items():
        other = ref.instances[wid]
        assert (inst.counts, inst.meas_delays_ms, inst.meas_resumed, inst.first_meas_rx_t) == \
               (other.counts, other.meas_delays_ms, other.meas_resumed, other.first_meas_rx_t)
    assert np.array_equal(fast.core.ctrl_seq, ref.core.ctrl_seq)


@pytest.mark.parametrize("dtype", ["float64", "float32"])
def test_a_stream_is_answered_byte_for_byte_as_the_batch_path_answers_it(tmp_path, dtype):
    rounds = [start_all()]
    for k in range(1, 400):  # one turbine per wake-up, then all three, a sample of the limiter in between
        changes = {"v_d": 0.2, "v_q": 0.0} if 150 <= k < 190 else {}  # a deep dip: the limiter acts
        rounds.append([meas(wt, k, k, **changes) for wt in TURBINES] if k % 3 == 0 else [meas(TURBINES[k % 3], k, k, **changes)])
    fast, fast_sink, ref, ref_sink = run_both(tmp_path, rounds, dtype=dtype)
    assert_same(fast, fast_sink, ref, ref_sink)
    limited = [wire.decode(d, header=True)["flags"] & 1 for d, _ in fast_sink.sent if len(d) == ctrl_bytes(True)]
    assert any(limited) and not all(limited)  # the limiter was active and released in the stream
    assert fast.instances[101].counts["ctrl_tx"] > 100


def test_bad_and_out_of_order_datagrams_are_counted_as_the_batch_path_counts_them(tmp_path):
    rounds = [start_all()] + [[meas(101, k, k)] for k in range(1, 30)]
    rounds += [
        [with_nan(meas(101, 30, 30))],                     # non-finite: a wire reject
        [meas(101, 31, 31, i_d=500.0)],                    # out of range
        [meas(101, 29, 29)],                               # stale
        [meas(101, 2**31 - 1, 32, t_sim=32 * TS)],         # inconsistent (an altered seq)
        [meas(7, 33, 33)],                                 # not a turbine id
        [meas(303, 33, 33)],                               # a turbine this SDC does not serve
        [meas(101, 35, 35), meas(101, 36, 36)],            # two queued, one lost before them
        [meas(101, 37, 37)[:-4]],                          # truncated
        [request(wire.Command.STOP_INSTANCE, 101, req_id=9), meas(101, 38, 38)],  # stopped: inactive
        [meas(102, 1, 1), request(wire.Command.STOP_INSTANCE, 102, req_id=10)],
        [meas(102, 2, 2)],
    ]
    fast, fast_sink, ref, ref_sink = run_both(tmp_path, rounds)
    assert_same(fast, fast_sink, ref, ref_sink)
    assert {"out_of_range", "stale", "inconsistent", "unknown_turbine", "unserved", "inactive"} <= set(fast.rejected)
    assert fast.instances[101].counts["meas_lost"] >= 1


def test_a_backup_that_took_over_answers_with_its_flag_as_the_batch_path(tmp_path):
    rounds = [[meas(101, k, k)] for k in range(1, 20)]  # mirrored: followed, not answered
    rounds += [[request(wire.Command.TAKEOVER, 101, req_id=3)]] + [[meas(101, k, k)] for k in range(20, 60)]
    fast, fast_sink, ref, ref_sink = run_both(tmp_path, rounds, role="backup")
    assert_same(fast, fast_sink, ref, ref_sink)
    flags = [wire.decode(d, header=True)["flags"] for d, _ in fast_sink.sent if len(d) == ctrl_bytes(True)]
    assert flags and all(f & 2 for f in flags)


def test_without_the_header_too(tmp_path):
    rounds = [start_all(header=False)] + [[meas(wt, k, k, header=False) for wt in TURBINES[:2]] for k in range(1, 50)]
    fast, fast_sink, ref, ref_sink = run_both(tmp_path, rounds, header=False)
    assert_same(fast, fast_sink, ref, ref_sink)
    assert fast.instances[102].counts["ctrl_tx"] == 49  # (the first MEAS, which initialises, by the batch path)


def test_a_backlog_of_several_samples_per_turbine_in_one_wake_up(tmp_path):
    rounds = [start_all()] + [[meas(wt, k, k) for k in range(1, 4) for wt in TURBINES]]  # initialised in it
    rounds += [[meas(wt, k, k) for wt in TURBINES for k in range(j, j + 4)] for j in range(4, 60, 4)]
    rounds += [[meas(101, 60, 60), request(wire.Command.STOP_INSTANCE, 102, req_id=7), meas(102, 60, 60),
                meas(205, 60, 60)]]
    fast, fast_sink, ref, ref_sink = run_both(tmp_path, rounds)
    assert_same(fast, fast_sink, ref, ref_sink)
    answered = [(m["wt"], m["meas_seq"]) for m in (wire.decode(d, header=True) for d, _ in fast_sink.sent)
                if m.type == wire.MsgType.CTRL]
    assert [s for w, s in answered if w == 101] == list(range(1, 61))  # each sample, in order
    assert [s for w, s in answered if w == 102] == list(range(1, 60))  # stopped before its 60th
    assert fast.instances[102].counts["meas_inactive"] == 1


# ---------------------------------------------------------------- the kernel on its own
def started_bank(dtype: str = "float64") -> ControllerBank:
    bank = ControllerBank(4, TS, dtype=dtype)
    bank.warm_up()
    bank.start(1, {"mask": 0})
    first = meas(101, 0, 0)
    step_round(bank, np.array([1]), decode_batch([first], wire.MsgType.MEAS, header=True)[0])  # initialises
    return bank


def values_of(data: bytes) -> tuple:
    return tuple(wire.decode(data, header=True)[k] for k in MEAS_FIELDS)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(v_d=st.floats(0.2, 1.6), i_d=st.floats(-3.0, 3.0), q=st.floats(-2.0, 2.0), now=st.floats(0.0, 4e9),
       seq=st.integers(1, 2**31 - 1))
def test_the_kernel_writes_what_wire_encode_writes(v_d, i_d, q, now, seq):
    a, b = started_bank(), started_bank()
    data = meas(101, 1, 1, v_d=v_d, i_d=i_d, q=q)
    valid, ctrl = step_round(a, np.array([1]), decode_batch([data], wire.MsgType.MEAS, header=True)[0])
    reference = pack_ctrl(ctrl, np.array([seq]), now)[0] if valid[0] else None
    ctrl_seq = np.zeros(4, dtype=np.int64)
    ctrl_seq[1] = seq - 1
    assert b.compiled_answers
    assert b.answer_datagrams([1], [data], [values_of(data)], ctrl_seq, False, True, now) == [reference]
    assert ctrl_seq[1] == (seq if valid[0] else seq - 1)


def test_the_kernel_refuses_what_does_not_fit_and_an_inactive_slot():
    bank = started_bank()
    data = meas(101, 1, 1)
    ctrl_seq = np.zeros(4, dtype=np.int64)
    ctrl_seq[1] = 2**31 - 1
    assert bank.answer_datagrams([1], [data], [values_of(data)], ctrl_seq, False, True, 7.0) == [None]  # seq > int32
    assert ctrl_seq[1] == 2**31  # used all the same, as pack_ctrl's numbering
    ctrl_seq[1] = 1
    assert bank.answer_datagrams([1], [data], [values_of(data)], ctrl_seq, False, True, 2.0**32) == [None]  # header sec
    assert ctrl_seq[1] == 2
    bank.stop(1)
    assert bank.answer_datagrams([1, 1], [data, data], [values_of(data)] * 2, ctrl_seq, False, True, 7.0) == [None, None]
    assert ctrl_seq[1] == 2  # not stepped: no seq used
