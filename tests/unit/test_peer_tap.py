"""Issue 42 item 8: what a run counts of a real GTNET-SKT card from the capture on its cable
(:mod:`scenarios.peer_tap`): MEAS out, CTRL in, AKs, the pauses of control with their times on the run
clock, and the AK stream's own view — from real frames written to a pcap file (scapy) and read back."""

from __future__ import annotations

import pytest
from scapy.layers.inet import IP, UDP
from scapy.layers.l2 import Dot1Q, Ether
from scapy.utils import wrpcap

from scenarios.peer_tap import frames, turbine_stats, udp_datagrams
from sdvisc import wire

CARD, SDC, VIP = "10.0.9.1", "10.0.0.21", "10.0.0.254"
TS = 0.00067
T0 = 1000.0  # the run clock's reading at t = 0 (k = 1: wall time)


def _meas(seq: int) -> bytes:
    return wire.encode(wire.MsgType.MEAS, {"wt": 101, "seq": seq, "t_sim": seq * TS, "v_d": 1.0, "v_q": 0.0,
                                           "i_d": 0.5, "i_q": 0.0, "p": 0.5, "q": 0.0, "v_dc": 1.0,
                                           "omega_meas": 1.0})


def _ctrl(seq: int) -> bytes:
    return wire.encode(wire.MsgType.CTRL, {"wt": 101, "seq": seq, "meas_seq": seq, "v_ref_d": 1.0, "v_ref_q": 0.0,
                                           "i_ref_d": 0.5, "i_ref_q": 0.0, "delta": 0.0, "omega": 1.0,
                                           "e_mag": 1.0, "flags": 0})


def _ak(seq: int, ak: int, ctrl_rx: int, age_ms: float) -> bytes:
    return wire.encode(wire.MsgType.AK, {"wt": 101, "seq": seq, "ak": ak, "ctrl_rx": ctrl_rx, "ctrl_age_ms": age_ms})


def _frame(src: str, dst: str, sport: int, dport: int, payload: bytes, t: float, vlan: bool = False):
    eth = Ether(src="02:00:00:00:09:01", dst="02:00:00:00:00:15")
    pkt = (eth / Dot1Q(vlan=7) if vlan else eth) / IP(src=src, dst=dst) / UDP(sport=sport, dport=dport) / payload
    pkt.time = t
    return pkt


def _capture(tmp_path, stop_s: float = 0.300, resume_s: float = 0.350):
    """wt1_1 for 0.5 s from t = 0.1: a MEAS and its CTRL every Ts, no CTRL between ``stop_s`` and
    ``resume_s``, an AK every 10 ms (ak = 0 once the last CTRL is 10 ms old)."""
    pkts, ctrl_rx, last_ctrl = [], 0, None
    n = int(0.5 / TS)
    next_ak, ak_seq = 0.1, 0
    for i in range(n):
        t = 0.1 + i * TS
        while next_ak <= t:
            age = (next_ak - last_ctrl) * 1e3 if last_ctrl is not None else 1e6
            ak_seq += 1
            pkts.append(_frame(CARD, VIP, 50101, wire.PORT_CONTROLLER, _ak(ak_seq, int(age <= 10.0), ctrl_rx, age),
                               T0 + next_ak, vlan=ak_seq == 3))
            next_ak += 0.010
        pkts.append(_frame(CARD, SDC, 50101, wire.PORT_SDC, _meas(i + 1), T0 + t))
        if not stop_s <= t < resume_s:
            ctrl_rx += 1
            last_ctrl = t + 0.0002
            pkts.append(_frame(SDC, CARD, wire.PORT_SDC, 50101, _ctrl(i + 1), T0 + last_ctrl))
    pkts.append(_frame(CARD, SDC, 50101, wire.PORT_SDC, b"\x00\x00\x00\x01", T0 + 0.7))  # a bad datagram
    path = tmp_path / "peer_tap.pcap"
    wrpcap(str(path), pkts)
    return path, n, ctrl_rx


def _stats(path):
    return turbine_stats(udp_datagrams(frames(path)), card_ip=CARD, header=False, turbines={"wt1_1": 50101},
                         from_wall=lambda wall: wall, t0=T0, step_s=TS)


def test_counts_and_the_pause_of_control_come_from_the_cable(tmp_path):
    path, n, ctrl_rx = _capture(tmp_path)
    s = _stats(path)
    row = s["turbines"]["wt1_1"]
    assert (row["meas_tx"], row["ctrl_rx"]) == (n, ctrl_rx)
    assert s["captured"]["undecoded"] == 1
    sent = [0.1 + i * TS + 0.0002 for i in range(n)]  # the CTRL times, had none been withheld
    (gap,) = row["ctrl_gaps_wall"]  # on the run clock, to the capture's microsecond
    assert gap[0] - T0 == pytest.approx(max(t for t in sent if t - 0.0002 < 0.300), abs=2e-6)
    assert gap[1] - T0 == pytest.approx(min(t for t in sent if t - 0.0002 >= 0.350), abs=2e-6)
    assert row["first_ctrl_rx_t"] == pytest.approx(0.1002, abs=1e-5)
    assert row["last_ctrl_wall"] - T0 == pytest.approx(0.1 + (n - 1) * TS + 0.0002, abs=1e-5)
    # the card's own view: every AK counted, its own CTRL count, the pause as ak = 0 to one AK period
    assert row["ak_tx"] == 50 and row["card_ctrl_rx"] <= ctrl_rx
    (zero,) = row["ak_zero"]
    assert zero[0] == pytest.approx(0.310, abs=0.0101) and zero[1] == pytest.approx(0.350, abs=0.0101)
    pause_ms = (gap[1] - gap[0]) * 1e3  # the AK before control came back saw (almost) all of it
    assert pause_ms - 10.0 <= row["ctrl_age_max_ms"] <= pause_ms
    assert row["ctrl_stale"] is None and row["rx_rejected"] is None  # the card's own: n/a


def test_without_a_pause_there_is_no_gap_and_ak_stays_one(tmp_path):
    path, n, _ = _capture(tmp_path, stop_s=9.0, resume_s=9.0)
    row = _stats(path)["turbines"]["wt1_1"]
    assert row["ctrl_gaps_wall"] == [] and row["ak_zero"] == [] and row["ctrl_rx"] == n


def test_an_unreadable_capture_leaves_the_counts_unknown_and_says_so(tmp_path, capsys):
    from types import SimpleNamespace

    from scenarios.peer_tap import PCAP, read

    (tmp_path / PCAP).write_bytes(b"\xd4\xc3\xb2")  # tcpdump ended before its file header was whole
    peer = SimpleNamespace(emulate=False, ip=CARD, framing="native", turbines={"wt1_1": 50101}, interface="eth9")
    run = SimpleNamespace(out=tmp_path, t0=T0, clock=SimpleNamespace(from_wall=lambda w: w),
                          scenario=SimpleNamespace(plant=SimpleNamespace(peer=peer), step_s=TS))
    assert read(run) is None
    assert "unreadable" in capsys.readouterr().err
