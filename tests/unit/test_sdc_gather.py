"""One sample's measurements answered in one round (sdc_unit.gather): the pure wait on a manual
clock, then the service on real loopback UDP sockets with its real epoll."""

from __future__ import annotations

import select
import socket
import threading

import pytest

from sdc_unit.gather import gather
from sdc_unit.service import SdcService
from sdvisc import wire
from sdvisc.config import SdcConfig
from tests.unit.test_sdc_admission import CONTROLLER, TS, meas, request


class Script:
    """A socket that delivers ``arrivals`` (time, datagram) on a manual clock."""

    def __init__(self, arrivals: list[tuple[float, bytes]]) -> None:
        self.t = 0.0
        self.arrivals = sorted(arrivals, key=lambda a: a[0])
        self.waits: list[float] = []

    def monotonic(self) -> float:
        return self.t

    def read_more(self, timeout_s: float) -> list[tuple[bytes, tuple]]:
        self.waits.append(timeout_s)
        due = [a for a in self.arrivals if a[0] <= self.t + timeout_s]
        if not due:
            self.t += timeout_s
            return []
        self.t = max(self.t, due[0][0])
        ready = [a for a in self.arrivals if a[0] <= self.t]
        self.arrivals = [a for a in self.arrivals if a[0] > self.t]
        return [(d, ("10.0.0.1", 1)) for _, d in ready]


def is_meas(data: bytes) -> bool:
    return data.startswith(b"M")


def test_the_wait_ends_with_the_last_expected_measurement():
    s = Script([(0.0002, b"M2"), (0.0005, b"M3"), (0.004, b"M4-next-sample")])
    got, read_at, complete = gather([(b"M1", ("a", 1))], 0.0, s.read_more, is_meas, expected=3, window_s=0.001,
                                    monotonic=s.monotonic)
    assert [d for d, _ in got] == [b"M1", b"M2", b"M3"] and complete
    assert read_at == [0.0, 0.0002, 0.0005]  # each one's own read time (its one-way delay ends there)
    assert s.t == pytest.approx(0.0005)  # not a moment longer than the last one


def test_a_late_measurement_costs_at_most_the_window():
    s = Script([(0.0002, b"M2"), (0.010, b"M3")])
    got, _, complete = gather([(b"M1", ("a", 1))], 0.0, s.read_more, is_meas, expected=3, window_s=0.001,
                              monotonic=s.monotonic)
    assert [d for d, _ in got] == [b"M1", b"M2"] and not complete
    assert s.t == pytest.approx(0.001) and s.waits == pytest.approx([0.001, 0.0008])  # then gives up


@pytest.mark.parametrize("first, window", [([(b"M1", ("a", 1))], 0.0), ([(b"R1", ("a", 1))], 0.001), ([], 0.001)])
def test_no_wait_without_a_window_for_commands_alone_or_for_nothing(first, window):
    s = Script([(0.0001, b"M2")])
    got, _, _ = gather(first, 0.0, s.read_more, is_meas, expected=2, window_s=window, monotonic=s.monotonic)
    assert got == first and s.waits == []


def test_a_complete_sample_is_not_held_back():
    s = Script([(0.0001, b"M2")])
    got, _, complete = gather([(b"M1", ("a", 1)), (b"M9", ("b", 1))], 0.0, s.read_more, is_meas, expected=2,
                    window_s=0.001, monotonic=s.monotonic)
    assert len(got) == 2 and complete and s.waits == []


# ---------------------------------------------------------------- the service on real UDP
def service_with(tmp_path, gather_steps: float) -> tuple[SdcService, socket.socket]:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    sock.setblocking(False)
    cfg = SdcConfig(step_s=TS, controller_vip="127.0.0.2", capacity=4, out_dir=str(tmp_path),
                    gather_steps=gather_steps, time_scale=1000.0)  # window = 0.9 Ts x 1000 = 0.6 s wall
    svc = SdcService(cfg, sock=sock)
    for wt in (101, 102):
        svc.serve([(request(wire.Command.START_INSTANCE, wt, req_id=wt), CONTROLLER)], 1.0)
    return svc, sock


def answered_by(svc: SdcService, poller, now: float) -> list[int]:
    """One wake-up of the service (read, gather, serve): the turbines it answered."""
    before = {w: i.counts["ctrl_tx"] for w, i in svc.instances.items()}
    svc.wake(now, poller)
    return sorted(w for w, i in svc.instances.items() if i.counts["ctrl_tx"] > before[w])


LATE_S = 0.2
"""How much later ``late_wt``'s MEAS is sent: inside the gathering window (0.6 s wall) and long after
the wake-up for 101's (at 5 ms a busy machine's stall between the send and the wake-up read both at
once, about one run in three)."""


def drain_with_late(svc: SdcService, sock: socket.socket, now: float, late_wt: int, seq: int) -> list[list[int]]:
    """wt 101's MEAS now, ``late_wt``'s :data:`LATE_S` later (real loopback UDP, the service's epoll);
    the turbines answered at each wake-up."""
    tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    poller = select.epoll()
    poller.register(sock.fileno(), select.EPOLLIN)
    try:
        dest = sock.getsockname()
        tx.sendto(meas(101, seq), dest)
        late = threading.Timer(LATE_S, lambda: tx.sendto(meas(late_wt, seq), dest))
        late.start()
        poller.poll(1.0)
        batches = [answered_by(svc, poller, now)]
        late.join()
        if poller.poll(2 * LATE_S + 0.5):
            batches.append(answered_by(svc, poller, now))
        return batches
    finally:
        poller.close()
        tx.close()


@pytest.mark.parametrize("gather_steps, rounds", [(0.9, 1), (0.0, 2)])
def test_two_turbines_measurements_arriving_apart_are_one_round(tmp_path, gather_steps, rounds):
    svc, sock = service_with(tmp_path, gather_steps)
    try:
        svc.serve([(meas(101, 1), ("127.0.0.1", 9)), (meas(102, 1), ("127.0.0.1", 9))], 1.0)
        batches = drain_with_late(svc, sock, 1.0 + TS, 102, seq=2)
        assert batches == ([[101, 102]] if rounds == 1 else [[101], [102]])
        assert svc.gathered == (1 if rounds == 1 else 0) and svc.gather_incomplete == 0
    finally:
        sock.close()


def test_a_turbine_gone_quiet_does_not_hold_the_others_back(tmp_path):
    svc, sock = service_with(tmp_path, 0.9)
    try:
        svc.serve([(meas(101, 1), ("127.0.0.1", 9)), (meas(102, 1), ("127.0.0.1", 9))], 1.0)
        # 102 has sent nothing for 5 samples (its path is down): 101's MEAS is answered at once
        svc.serve([(meas(101, k), ("127.0.0.1", 9)) for k in range(2, 7)], 1.0 + 5 * TS)
        batches = drain_with_late(svc, sock, 1.0 + 6 * TS, 102, seq=7)
        assert batches[0] == [101]
        assert svc.gathered == 0
    finally:
        sock.close()
