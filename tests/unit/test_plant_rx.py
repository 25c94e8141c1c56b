"""The plant's turbine receive step (plant.service.endpoint_rx.receive) on its own, and the service's
``_drain`` (plant.service) with its core (plant.service.core.PlantCore) around it (issue 13).

The receive step needs no socket, clock or model: an ``Endpoint`` is all its state. Only the
``_drain`` tests at the end use stand-ins: a fake socket and poller that hand out queued
datagrams, and a model that records what ``apply_remote`` receives.
"""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest
from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st

from plant.service import endpoint_rx
from plant.service.core import Endpoint, PlantCore
from plant.service.endpoint_rx import APPLY, IGNORE, MAX_REF_PU, REASONS, REQUEST, receive
from plant.service.main import PlantService
from sdvisc import wire
from sdvisc.config import PlantConfig
from sdvisc.vocabulary import MEAS_FIELDS

SDC = "10.0.0.21"
VIP = "10.0.0.254"
OTHER = "10.0.1.2"
WID = 101
FUZZ = settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def endpoint(meas_seq: int = 100, ctrl_seq: int = -1, sdc: str | None = SDC) -> Endpoint:
    ep = Endpoint("wt1_1", WID, 0, streaming=sdc is not None,
                  sdc_addr=(sdc, wire.PORT_SDC) if sdc else None, meas_seq=meas_seq)
    ep.ctrl_seq = ctrl_seq
    return ep


def ctrl(meas_seq: int, v=(1.0, 0.1), i=(0.5, -0.2), wt: int = WID, flags: int = 0, header: bool = True,
         own_seq: int | None = None, sent: tuple[int, int] = (5, 6)) -> bytes:
    values = {"wt": wt, "seq": meas_seq if own_seq is None else own_seq, "meas_seq": meas_seq, "v_ref_d": v[0], "v_ref_q": v[1],
              "i_ref_d": i[0], "i_ref_q": i[1], "delta": 0.3, "omega": 1.0, "e_mag": 1.02, "flags": flags}
    return wire.encode(wire.MsgType.CTRL, values, header=wire.Header(meas_seq & wire.UINT32_MAX, *sent)
                       if header else None)


def request(cmd: int, sdc_ip: int | str = SDC, wt: int = WID) -> bytes:
    word = wire.ip_to_i32(sdc_ip) if isinstance(sdc_ip, str) else sdc_ip
    values = {"req_id": 1, "cmd": int(cmd), "wt": wt, "sdc_ip": word, "mask": 0, "h": 0.0, "d": 0.0,
              "m_q": 0.0, "v_ref": 0.0, "q_ref": 0.0, "supp": 0}
    return wire.encode(wire.MsgType.REQUEST, values, header=wire.Header(1, 2, 3))


def patch_word(data: bytes, body_word: int, raw: int) -> bytes:
    at = 4 * (3 + body_word)
    return data[:at] + struct.pack(">I", raw) + data[at + 4:]


def rx(ep: Endpoint, data: bytes, src: str = SDC, **kw):
    return receive(ep, data, (src, wire.PORT_SDC), header=True, controller_ip=VIP, **kw)


def rejections(ep: Endpoint) -> dict[str, int]:
    return {k[len("rx_reject_"):]: n for k, n in ep.counts.items() if k.startswith("rx_reject_") and n}


def assert_consistent(ep: Endpoint) -> None:
    reasons = rejections(ep)
    assert set(reasons) <= set(REASONS)
    assert sum(reasons.values()) == ep.counts["rx_rejected"]


# --- one datagram, one outcome -----------------------------------------------------------------


def test_genuine_ctrl_is_applied_and_advances_ctrl_seq():
    ep = endpoint()
    stats = wire.DecodeStats()
    action, msg = rx(ep, ctrl(100), stats=stats)
    assert action == APPLY and msg["meas_seq"] == 100 and ep.ctrl_seq == 100
    assert ep.counts["rx_rejected"] == 0 and ep.counts["ctrl_stale"] == 0 and not rejections(ep)
    assert stats.ok == 1 and stats.rejected == 0


def test_stale_ctrl_is_counted_as_ctrl_stale_not_as_rejected():
    ep = endpoint(ctrl_seq=50)
    assert rx(ep, ctrl(50)) == (IGNORE, None)
    assert rx(ep, ctrl(49)) == (IGNORE, None)
    assert ep.counts["ctrl_stale"] == 2 and ep.counts["rx_rejected"] == 0 and ep.ctrl_seq == 50


def test_stream_requests_from_the_controller_are_carried_out():
    ep = endpoint(sdc=None)
    action, msg = rx(ep, request(wire.Command.STREAM_START), src=VIP)
    assert action == REQUEST and msg["cmd"] == wire.Command.STREAM_START
    assert rx(ep, request(wire.Command.STREAM_STOP, sdc_ip=0), src=VIP)[0] == REQUEST  # sdc_ip unused
    assert ep.counts["rx_rejected"] == 0


CASES = {
    "length": lambda: ctrl(100)[:-1],
    "length-empty": lambda: b"",
    "length-long": lambda: ctrl(100) + b"\0\0\0\0",
    "length-header-only": lambda: ctrl(100)[:12],
    "type": lambda: patch_word(ctrl(100), 0, 99),
    "nonfinite": lambda: patch_word(ctrl(100), 4, 0x7FC00000),
    "nonfinite-inf": lambda: patch_word(ctrl(100), 7, 0xFF800000),
    "range": lambda: patch_word(request(wire.Command.STREAM_START), 2, 99),
    "unexpected_type": lambda: wire.encode(wire.MsgType.HEARTBEAT, {"sdc_id": 1, "seq": 1, "n_instances": 1,
                                                                     "t_wall": 1.0}, header=wire.Header(1, 2, 3)),
    "unexpected_type-meas": lambda: wire.encode(wire.MsgType.MEAS, {
        "wt": WID, "seq": 1, "t_sim": 0.0, "v_d": 1.0, "v_q": 0.0, "i_d": 0.0, "i_q": 0.0, "p": 0.0, "q": 0.0,
        "v_dc": 1.0, "omega_meas": 1.0}, header=wire.Header(1, 2, 3)),
    "wrong_turbine": lambda: ctrl(100, wt=102),
    "not_from_sdc": lambda: ctrl(100),  # sent from OTHER below
    "future_seq": lambda: ctrl(101),
    "future_seq-max": lambda: ctrl(wire.INT32_MAX),
    "out_of_range": lambda: ctrl(100, v=(MAX_REF_PU, 0.1)),
    "out_of_range-i": lambda: ctrl(100, i=(-8.0, -8.0)),
    "out_of_range-max": lambda: patch_word(ctrl(100), 6, 0x7F7FFFFF),  # i_ref_d = float32 max
    "bad_request": lambda: request(wire.Command.VISC_ON),
    "bad_request-zero-ip": lambda: request(wire.Command.STREAM_START, sdc_ip=0),
    "bad_request-broadcast": lambda: request(wire.Command.STREAM_START, sdc_ip="255.255.255.255"),
    "bad_request-multicast": lambda: request(wire.Command.STREAM_START, sdc_ip="224.0.0.1"),
    "not_from_controller": lambda: request(wire.Command.STREAM_START),  # sent from the SDC's address
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_each_rejection_is_counted_once_under_its_reason(case):
    reason = case.split("-")[0]
    ep = endpoint(meas_seq=100, ctrl_seq=40)
    data = CASES[case]()
    is_request = data[12:16] == struct.pack(">i", wire.MsgType.REQUEST)
    src = {"not_from_sdc": OTHER, "not_from_controller": SDC}.get(reason, VIP if is_request else SDC)
    stats = wire.DecodeStats()
    assert rx(ep, data, src=src, stats=stats) == (IGNORE, None)
    assert rejections(ep) == {reason: 1} and ep.counts["rx_rejected"] == 1
    assert ep.ctrl_seq == 40 and ep.counts["ctrl_stale"] == 0
    if reason in wire.REJECT_REASONS:
        assert stats.rejected == 1 and getattr(stats, reason) == 1
    else:
        assert stats.ok == 1 and stats.rejected == 0
    assert rx(ep, ctrl(100))[0] == APPLY  # the endpoint goes on serving


def test_ctrl_before_any_stream_start_is_not_from_sdc_and_source_check_can_be_disabled():
    ep = endpoint(meas_seq=0, sdc=None)
    assert rx(ep, ctrl(0))[0] == IGNORE and rejections(ep) == {"not_from_sdc": 1}
    ep = endpoint(meas_seq=5)
    assert rx(ep, ctrl(5), src=OTHER, check_source=False)[0] == APPLY
    assert rx(ep, request(wire.Command.STREAM_STOP), src=OTHER, check_source=False)[0] == REQUEST


def test_a_future_meas_seq_never_blocks_later_genuine_ctrl():
    """Before the check, a CTRL with meas_seq = 2**31-1 made every later genuine CTRL 'stale'."""
    ep = endpoint(meas_seq=10, ctrl_seq=9)
    assert rx(ep, ctrl(wire.INT32_MAX))[0] == IGNORE
    assert ep.ctrl_seq == 9
    for seq in range(10, 20):
        ep.meas_seq = seq
        assert rx(ep, ctrl(seq))[0] == APPLY
    assert ep.counts["ctrl_stale"] == 0 and rejections(ep) == {"future_seq": 1}


def test_max_ref_bound_is_far_above_genuine_references():
    assert MAX_REF_PU >= 5 * 1.5  # SDC current limit i_max is 1.5 p.u.; converter voltage ~1 p.u.
    ep = endpoint()
    assert rx(ep, ctrl(100, v=(1.3, -1.3), i=(1.5, 0.0)))[0] == APPLY


def test_unicast_word():
    assert endpoint_rx.is_unicast_word(wire.ip_to_i32("10.0.0.21"))
    assert endpoint_rx.is_unicast_word(wire.ip_to_i32("192.168.1.20"))  # a negative word
    assert endpoint_rx.is_unicast_word(wire.ip_to_i32("223.255.255.254"))
    for bad in ("0.0.0.0", "0.1.2.3", "224.0.0.1", "239.1.1.1", "240.0.0.1", "255.255.255.255"):
        assert not endpoint_rx.is_unicast_word(wire.ip_to_i32(bad)), bad


# --- hypothesis: hostile traffic mixed with genuine traffic -----------------------------------

float_words = st.sampled_from([0x7FC00000, 0xFF800000, 0x7F800000, 0x7F7FFFFF, 0xFF7FFFFF, 0x00000001,
                               0x41300000, 0xC1300000])  # NaN, -Inf, +Inf, +-f32 max, subnormal, +-11.0
finite_refs = st.one_of(st.floats(-2.0, 2.0, width=32), st.floats(allow_nan=False, allow_infinity=False, width=32))
seqs = st.one_of(st.integers(0, 60), st.integers(wire.INT32_MIN, wire.INT32_MAX),
                 st.sampled_from([wire.INT32_MIN, -1, 0, 1, wire.INT32_MAX]))
usually = st.sampled_from([True, True, True, False])


@st.composite
def hostile(draw) -> tuple[bytes, str]:
    """A datagram that may be anything: forged or mutated CTRL/REQUEST, random bytes; mostly from
    the expected address and for this turbine, so that the later checks are reached."""
    kind = draw(st.sampled_from(["ctrl", "ctrl", "request", "bytes", "mutant"]))
    expected_src = VIP if kind == "request" else SDC
    src = expected_src if draw(usually) else draw(st.sampled_from([SDC, VIP, OTHER]))
    wt = WID if draw(usually) else draw(st.sampled_from([102, 0, -1, wire.INT32_MAX]))
    if kind == "ctrl":
        data = ctrl(draw(seqs), v=(draw(finite_refs), draw(finite_refs)), i=(draw(finite_refs), draw(finite_refs)),
                    wt=wt, flags=draw(st.integers(0, 3)))
        if not draw(usually):
            data = patch_word(data, draw(st.integers(0, 11)), draw(float_words))
    elif kind == "request":
        stream = [wire.Command.STREAM_START, wire.Command.STREAM_STOP]
        data = request(draw(st.sampled_from(stream if draw(st.booleans()) else list(wire.Command))), wt=wt,
                       sdc_ip=draw(st.one_of(st.sampled_from([0, -1, wire.ip_to_i32(SDC), wire.ip_to_i32(OTHER)]),
                                             st.integers(wire.INT32_MIN, wire.INT32_MAX))))
    elif kind == "bytes":
        data = draw(st.binary(max_size=80))
    else:
        buf = bytearray(ctrl(draw(st.integers(0, 60))))
        for _ in range(draw(st.integers(1, 6))):
            bit = draw(st.integers(0, 8 * len(buf) - 1))
            buf[bit // 8] ^= 1 << (bit % 8)
        data = bytes(buf[:draw(st.integers(0, len(buf) + 4))])
    return data, src


steps = st.lists(st.one_of(
    st.tuples(st.just("meas"), st.integers(1, 3)),  # the plant sends MEAS (seq advances)
    st.tuples(st.just("genuine"), st.integers(0, 5)),  # the SDC answers one of the last MEAS (maybe again)
    st.tuples(st.just("hostile"), hostile()),
), max_size=40)


@FUZZ
@given(steps)
@example([("meas", 1), ("hostile", (request(wire.Command.STREAM_START, wt=WID, sdc_ip=wire.ip_to_i32(OTHER)), VIP)),
          ("hostile", (ctrl(2), OTHER))])  # the controller names another SDC (a failover): its CTRL is applied
def test_hostile_traffic_never_raises_applies_nothing_implausible_and_never_blocks_control(script):
    ep = endpoint(meas_seq=1, ctrl_seq=-1)
    ep.counts["rx_reject_internal"] = 0
    for op, arg in script:
        if op == "meas":
            ep.meas_seq += arg
            continue
        data, src = (ctrl(max(ep.meas_seq - arg, 0)), ep.sdc_addr[0]) if op == "genuine" else arg
        before = dict(ep.counts)
        ctrl_seq_before = ep.ctrl_seq
        action, msg = rx(ep, data, src=src)
        event(action)
        changed = {k: ep.counts.get(k, 0) - before.get(k, 0) for k in set(ep.counts) | set(before)}
        changed = {k: d for k, d in changed.items() if d}
        if action == APPLY:
            # from the SDC the endpoint follows: its first, or one a STREAM_START from the controller named
            assert not changed and src == ep.sdc_addr[0] and msg.type == wire.MsgType.CTRL and msg["wt"] == WID
            assert ctrl_seq_before < msg["meas_seq"] == ep.ctrl_seq <= ep.meas_seq
            for k in ("v_ref_d", "v_ref_q", "i_ref_d", "i_ref_q"):
                assert math.isfinite(msg[k])
            assert math.hypot(msg["v_ref_d"], msg["v_ref_q"]) <= MAX_REF_PU
            assert math.hypot(msg["i_ref_d"], msg["i_ref_q"]) <= MAX_REF_PU
        elif action == REQUEST:
            assert not changed and src == VIP and msg["wt"] == WID
            assert msg["cmd"] in (wire.Command.STREAM_START, wire.Command.STREAM_STOP)
            if msg["cmd"] == wire.Command.STREAM_START:  # what PlantCore._on_request does
                ep.sdc_addr = (wire.i32_to_ip(msg["sdc_ip"]), wire.PORT_SDC)
        else:
            assert action == IGNORE and msg is None and ep.ctrl_seq == ctrl_seq_before
            if changed == {"ctrl_stale": 1}:
                event("ctrl_stale")
                continue
            assert len(changed) == 2 and changed.pop("rx_rejected") == 1, changed
            ((key, n),) = changed.items()
            event(key)
            assert n == 1 and key.startswith("rx_reject_") and key[len("rx_reject_"):] in REASONS
            assert key != "rx_reject_internal"
        assert_consistent(ep)
    # whatever came before, the next genuine answer to a new measurement is applied
    # (a forged STREAM_START can only come from the controller's own address)
    ep.meas_seq += 1
    sdc = ep.sdc_addr[0]
    assert rx(ep, ctrl(ep.meas_seq), src=sdc)[0] == APPLY


# --- PlantService._drain and PlantCore with stand-ins for the socket, poller and model --------


class FakeSock:
    def __init__(self, fd: int, queue: list) -> None:
        self.fd, self.queue = fd, queue

    def fileno(self) -> int:
        return self.fd

    def recvfrom(self, _n: int):
        if not self.queue:
            raise BlockingIOError
        item = self.queue.pop(0)
        if isinstance(item, BaseException):
            raise item
        return item


class FakePoller:
    def __init__(self, fds) -> None:
        self.fds = list(fds)

    def poll(self, _timeout):
        return [(fd, 1) for fd in self.fds]


class RecordingModel:
    """Stand-in for the plant model: records apply_remote and set_mode calls; one turbine."""

    def __init__(self) -> None:
        self.applied: list[tuple] = []
        self.modes: list[tuple] = []

    def apply_remote(self, index, v_ref_d, v_ref_q, i_ref_d, i_ref_q) -> None:
        self.applied.append((index.tolist(), v_ref_d.tolist(), v_ref_q.tolist(), i_ref_d.tolist(), i_ref_q.tolist()))

    def set_mode(self, index: int, mode: str) -> None:
        self.modes.append((index, mode))

    def step(self) -> None:
        pass

    def measurements(self) -> dict:
        return {key: np.ones(1) for key in MEAS_FIELDS}


def service(queue: list, model=None) -> PlantService:
    svc = PlantService.__new__(PlantService)  # no sockets, no model build
    cfg = PlantConfig(duration_s=None, turbines=[{"name": "wt1_1", "wid": WID, "ip": "10.0.1.1"}], out_dir="unused",
                      step_s=0.001, controller_vip=VIP)
    svc.core = PlantCore(cfg, model or RecordingModel(), [0])
    ep, sock = svc.core.endpoints[0], FakeSock(7, queue)
    svc.socks, svc.by_fd = {ep.name: sock}, {7: (ep, sock)}
    svc.poller, svc.commands = FakePoller([7]), None
    return svc


def test_drain_applies_only_the_newest_plausible_ctrl_and_counts_the_rest():
    queue = [(request(wire.Command.STREAM_START), (VIP, wire.PORT_CONTROLLER))]
    svc = service(queue)
    svc._drain(1.0)
    ep = svc.core.endpoints[0]
    assert ep.streaming and ep.sdc_addr == (SDC, wire.PORT_SDC) and svc.core.model.modes == [(0, "remote")]
    ep.meas_seq = 3
    queue += [(ctrl(2), (SDC, wire.PORT_SDC)),
              (ctrl(3, v=(float(np.float32(3e38)), 0.0)), (SDC, wire.PORT_SDC)),  # out_of_range
              (ctrl(wire.INT32_MAX), (SDC, wire.PORT_SDC)),  # future_seq
              (b"\xff" * 7, (OTHER, 1)),  # length
              (ctrl(3), (OTHER, wire.PORT_SDC)),  # not_from_sdc
              (ctrl(1), (SDC, wire.PORT_SDC))]  # stale
    svc._drain(1.001)
    assert svc.core.model.applied == []  # at the start of the next step, the newest one only
    svc.core.step(1.001)
    assert svc.core.model.applied == [([0], [1.0], [pytest.approx(0.1)], [0.5], [pytest.approx(-0.2)])]
    assert ep.counts["ctrl_rx"] == 1 and ep.counts["ctrl_stale"] == 1 and ep.ctrl_seq == 2
    assert rejections(ep) == {"out_of_range": 1, "future_seq": 1, "length": 1, "not_from_sdc": 1}
    summary_counts = {k: ep.counts[k] for k in ("rx_rejected", "requests_rx")}
    assert summary_counts == {"rx_rejected": 4, "requests_rx": 1}
    assert endpoint_rx.rejections_by_reason([ep.counts]) == {"future_seq": 1, "length": 1, "not_from_sdc": 1,
                                                            "out_of_range": 1}


def test_drain_survives_an_exception_from_one_datagram_and_a_socket_error(capsys):
    class BrokenModel(RecordingModel):
        def set_mode(self, index, mode):
            raise RuntimeError("model refused")

    queue = [(request(wire.Command.STREAM_START), (VIP, wire.PORT_CONTROLLER)),
             (request(wire.Command.STREAM_STOP), (VIP, wire.PORT_CONTROLLER))]
    svc = service(queue, BrokenModel())
    ep = svc.core.endpoints[0]
    endpoint_rx._internal_logged.clear()
    svc._drain(1.0)  # both requests raise inside the model: counted, the loop goes on
    assert rejections(ep) == {"internal": 2} and ep.counts["rx_rejected"] == 2
    err = capsys.readouterr().err
    assert err.count("rx_reject_internal") == 1 and "model refused" in err  # logged once
    queue += [ConnectionRefusedError(), (ctrl(0), (SDC, wire.PORT_SDC))]
    svc._drain(1.001)
    assert ep.counts["rx_socket_error"] == 1 and ep.counts["ctrl_rx"] == 0
    svc._drain(1.002)  # the datagram after the socket error is still read (and accounted): rejected, as the
    # refused STREAM_START left the turbine without a stream (the model is asked first, plant/service/core.py)
    assert ep.counts["ctrl_rx"] == 0 and not ep.streaming
    assert rejections(ep) == {"internal": 2, "not_from_sdc": 1}  # no SDC named: none is its SDC
    assert capsys.readouterr().err == ""


def test_ctrl_lost_on_the_way_is_recorded_where_the_path_delivered_again():
    """The CTRL's own seq (the SDC's counter) jumps where the path lost some: the first one through
    again is recorded with its send time (scenarios.interruptions: what the network needed)."""
    queue = [(request(wire.Command.STREAM_START), (VIP, wire.PORT_CONTROLLER))]
    svc = service(queue)
    svc._drain(1.0)
    ep = svc.core.endpoints[0]
    ep.meas_seq = 20
    for own, meas, sent in ((1, 1, (2, 0)), (2, 2, (2, 670_000)), (6, 7, (2, 4_020_000)), (7, 8, (2, 4_690_000))):
        queue.append((ctrl(meas, own_seq=own, sent=sent), (SDC, wire.PORT_SDC)))
        svc._drain(2.1)
    assert ep.counts["ctrl_rx"] == 4
    assert ep.ctrl_resumed == [[pytest.approx(2.00402), 3]]  # 3, 4, 5 lost; 6 sent at 2.00402 s
    # a lower seq (a backup took over, or the SDC restarted) is a new counter, not a loss
    queue.append((ctrl(9, own_seq=1, sent=(2, 5_360_000)), (SDC, wire.PORT_SDC)))
    svc._drain(2.2)
    assert ep.counts["ctrl_rx"] == 5 and len(ep.ctrl_resumed) == 1
