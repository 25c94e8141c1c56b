"""The SDC service's admission (sdc_unit.core) against random and mutated datagrams (issue: one bad packet must
never stop control). No Mininet: the service gets a loopback socket and is fed datagrams directly."""

from __future__ import annotations

import socket
import struct

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sdc_unit.admission import (
    CONFIRM_WINDOW,
    MEAS_ABS_MAX_PU,
    T_SIM_MAX_S,
    SeqGate,
    bad_params,
    meas_out_of_range,
    values_out_of_range,
)
from sdc_unit.service import SdcService
from sdvisc import wire
from sdvisc.config import SdcConfig
from sdvisc.vocabulary import MEAS_FIELDS

TS = 0.00067
CONTROLLER = ("127.0.0.2", wire.PORT_CONTROLLER)
TURBINE = ("127.0.0.1", wire.PORT_TURBINE)


def meas(wt: int, seq: int, t_sim: float | None = None, vd: float = 1.0) -> bytes:
    values = {"wt": wt, "seq": seq, "t_sim": seq * TS if t_sim is None else t_sim, "v_d": vd, "v_q": 0.05,
              "i_d": 0.5, "i_q": -0.1, "p": 0.5, "q": 0.1, "v_dc": 1.0, "omega_meas": 1.0}
    return wire.encode(wire.MsgType.MEAS, values, header=wire.Header(seq, 0, 0))


def request(cmd: wire.Command, wt: int, req_id: int = 1, **params) -> bytes:
    values = {"req_id": req_id, "cmd": int(cmd), "wt": wt, "sdc_ip": wire.ip_to_i32("127.0.0.1"), "mask": 0,
              "h": 0.0, "d": 0.0, "m_q": 0.0, "v_ref": 0.0, "q_ref": 0.0, "supp": 0}
    values.update(params)
    return wire.encode(wire.MsgType.REQUEST, values, header=wire.Header(req_id, 0, 0))


@pytest.fixture
def service(tmp_path):
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    sock.setblocking(False)
    svc = SdcService(SdcConfig(step_s=TS, controller_vip="127.0.0.2", capacity=4, out_dir=str(tmp_path)), sock=sock)
    yield svc
    sock.close()


def feed(svc: SdcService, datagrams: list[tuple[bytes, tuple]]) -> None:
    svc.serve(datagrams, now=1.0)


# ---------------------------------------------------------------------------- the sequence gate
def test_gate_accepts_a_stream_with_losses_and_rejects_duplicates():
    gate = SeqGate(TS)
    assert [gate.admit(s, s * TS) for s in (1, 2, 5, 6)] == [None] * 4  # 3 and 4 lost: still consistent
    assert gate.admit(6, 6 * TS) == "stale" and gate.admit(2, 2 * TS) == "stale"


def test_gate_rejects_an_altered_seq_and_keeps_serving_the_stream():
    gate = SeqGate(TS)
    for s in range(1, 10):
        assert gate.admit(s, s * TS) is None
    assert gate.admit(2**31 - 1, 10 * TS) == "inconsistent"  # would make every later sample "stale"
    assert gate.admit(10 | (1 << 20), 10 * TS) == "inconsistent"
    assert gate.admit(10, 10 * TS + 0.5) == "inconsistent"  # altered t_sim
    assert gate.admit(10, 10 * TS) is None and gate.last_seq == 10


def test_gate_follows_a_restarted_stream_after_one_confirming_sample():
    gate = SeqGate(TS)
    for s in range(100, 110):
        gate.admit(s, s * TS)
    assert gate.admit(1, 0.0) == "inconsistent"  # the plant restarted: seq and time start over
    assert gate.admit(2, TS) is None and gate.last_seq == 2
    gate.reset()
    assert gate.admit(7, 123.0) is None  # a new stream (START_INSTANCE) takes its first sample as is


def test_a_burst_of_late_datagrams_of_the_stream_is_stale_not_a_restart():
    # seen on AF_XDP ports: a failed link's queue released 0.3 s later, when the link came back — 430
    # samples behind, in order; two of them once confirmed a "restarted stream" and the SDC stepped its
    # controllers with the old samples again
    gate = SeqGate(TS)
    for s in range(1, 1001):
        assert gate.admit(s, s * TS) is None
    assert [gate.admit(s, s * TS) for s in range(570, 600)] == ["stale"] * 30
    assert gate.last_seq == 1000 and gate.admit(1001, 1001 * TS) is None


def test_gate_does_not_confirm_a_jump_by_a_far_sample():
    gate = SeqGate(TS)
    gate.admit(1, TS)
    assert gate.admit(1000, 1.0) == "inconsistent"
    assert gate.admit(1000 + CONFIRM_WINDOW + 1, 1.0 + (CONFIRM_WINDOW + 1) * TS) == "inconsistent"


def test_range_checks():
    good = {"t_sim": 1.0, "v_d": 1.0, "v_q": 0.0, "i_d": 0.5, "i_q": 0.0, "p": 0.5, "q": 0.0, "v_dc": 1.0,
            "omega_meas": 1.0}
    assert not meas_out_of_range(good)
    assert meas_out_of_range({**good, "i_d": 3e38}) and meas_out_of_range({**good, "t_sim": -1.0})
    assert bad_params({"mask": 1 | 8, "h": 1e30, "d": 0, "m_q": 0, "v_ref": 1.0, "q_ref": 0}) == ["h"]
    assert bad_params({"mask": 0, "h": -5.0, "d": 0, "m_q": 0, "v_ref": 0.0, "q_ref": 0}) == []


# ---------------------------------------------------------------------------- the service
def test_unknown_turbine_and_foreign_commands_are_dropped_and_counted(service):
    feed(service, [(request(wire.Command.START_INSTANCE, 101), CONTROLLER)])
    feed(service, [(meas(1, 1), TURBINE), (meas(-2**31, 1), TURBINE), (meas(101, 1), TURBINE),
                   (request(wire.Command.STOP_INSTANCE, 101), TURBINE),  # a turbine may not command the SDC
                   (request(wire.Command.START_INSTANCE, 5), CONTROLLER),
                   (request(wire.Command.START_INSTANCE, 102, h=1e30, mask=1), CONTROLLER)])
    assert service.rejected["unknown_turbine"] == 3
    assert service.rejected["not_controller"] == 1 and service.rejected["bad_params"] == 1
    assert service.instances[101].active and service.instances[101].counts["ctrl_tx"] == 1


def test_capacity_is_never_exceeded(service):
    for k in range(10):
        feed(service, [(request(wire.Command.START_INSTANCE, 101 + k), CONTROLLER)])
    assert len(service.instances) == service.bank.capacity - 1 and service.rejected["capacity"] == 10 - len(
        service.instances)


def _mutations():
    real = st.sampled_from([meas(101, 5), meas(101, 5, vd=0.9), request(wire.Command.STOP_INSTANCE, 101),
                            request(wire.Command.START_INSTANCE, 101)])
    flipped = st.tuples(real, st.integers(0, 4 * 15 * 8 - 1)).map(
        lambda rb: bytes(b ^ (1 << (rb[1] % 8)) if i == (rb[1] // 8) % len(rb[0]) else b for i, b in enumerate(rb[0])))
    truncated = st.tuples(real, st.integers(0, 60)).map(lambda rb: rb[0][: rb[1]])
    extreme_words = st.lists(st.sampled_from([0, 1, 2, 101, 2**31 - 1, -2**31, 0x7FC00000, 0x7F800000, 0x7F7FFFFF,
                                              -1]), min_size=15, max_size=15).map(
        lambda ws: struct.pack(">3I", 1, 0, 0) + struct.pack(">12i", *[1] + ws[:11]))
    return st.one_of(st.binary(max_size=80), flipped, truncated, extreme_words)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(junk=st.lists(_mutations(), max_size=30), every=st.integers(1, 5))
def test_junk_never_stops_control_and_is_counted(service, junk, every):
    """A genuine stream interleaved with random and mutated datagrams from the turbine's own port:
    nothing raises, every datagram is used or counted once, and the genuine stream is answered to
    its last sample (no junk can block it)."""
    feed(service, [(request(wire.Command.START_INSTANCE, 101), CONTROLLER)])
    inst = service.instances[101]
    base_rx = inst.counts["meas_rx"]
    base_rejected = sum(service.rejected.values()) + service.rx_stats.rejected
    seq0 = (inst.gate.last_seq if inst.gate.last_seq > 0 else 0) + 1000
    stream, sent = [], 0
    for k, j in enumerate(junk):
        if k % every == 0:
            stream.append((meas(101, seq0 + sent), TURBINE))
            sent += 1
        stream.append((j, TURBINE))
    tail = [(meas(101, seq0 + sent + i), TURBINE) for i in range(3)]
    feed(service, stream)
    feed(service, tail)
    used = inst.counts["meas_rx"] - base_rx
    rejected = sum(service.rejected.values()) + service.rx_stats.rejected - base_rejected
    handled = len(stream) + len(tail)
    assert used + rejected == handled
    assert service.rejected["internal"] == 0
    assert inst.gate.last_seq == seq0 + sent + 2  # the last genuine sample was used


def test_the_range_check_agrees_with_a_vectorised_statement_of_it():
    rng = np.random.default_rng(8)
    specials = [np.inf, -np.inf, MEAS_ABS_MAX_PU, -MEAS_ABS_MAX_PU, np.nextafter(MEAS_ABS_MAX_PU, 1e9),
                -0.0, T_SIM_MAX_S, np.nextafter(T_SIM_MAX_S, 1e30), -1e-300]
    for _ in range(2000):
        row = rng.uniform(-120.0, 120.0, size=1 + len(MEAS_FIELDS))
        row[0] = rng.uniform(-1.0, 50.0)
        for _ in range(rng.integers(0, 4)):
            row[rng.integers(len(row))] = rng.choice(specials)
        expected = row[0] < 0.0 or row[0] > T_SIM_MAX_S or bool((np.abs(row[1:]) > MEAS_ABS_MAX_PU).any())
        assert values_out_of_range(row[0], row[1:].tolist()) == expected
