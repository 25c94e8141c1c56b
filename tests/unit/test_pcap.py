"""Unit tests of host_tools.pcap: the scapy GTNET layer, read_pcap and the command line tool."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from scapy.layers.inet import ICMP, IP, TCP, UDP
from scapy.layers.l2 import Ether
from scapy.packet import Raw
from scapy.utils import wrpcap

from host_tools import pcap
from sdvisc import wire
from sdvisc.wire import Header, MsgType, encode

TURBINE = "10.0.1.1"
SDC = "10.0.2.1"

MEAS_VALUES = {
    "wt": 101, "seq": 5, "t_sim": 0.5, "v_d": 1.0, "v_q": -0.25, "i_d": 0.75, "i_q": 0.125,
    "p": 0.5, "q": 0.0, "v_dc": 1.0, "omega_meas": 1.0,
}
CTRL_VALUES = {
    "wt": 101, "seq": 3, "meas_seq": 5, "v_ref_d": 1.0, "v_ref_q": 0.5, "i_ref_d": 0.75,
    "i_ref_q": 0.25, "delta": 0.125, "omega": 1.0, "e_mag": 1.125, "flags": 1,
}
REQUEST_VALUES = {
    "req_id": 9, "cmd": int(wire.Command.SET_PARAMS), "wt": 101, "sdc_ip": wire.ip_to_i32("192.168.0.7"),
    "mask": int(wire.ParamMask.H | wire.ParamMask.D), "h": 4.0, "d": 10.0, "m_q": 0.0, "v_ref": 1.0,
    "q_ref": 0.0, "supp": 0,
}


def udp_frame(src: str, sport: int, dst: str, dport: int, payload: bytes, when: float) -> Ether:
    frame = Ether() / IP(src=src, dst=dst) / UDP(sport=sport, dport=dport) / Raw(payload)
    frame.time = when
    return frame


@pytest.fixture()
def capture(tmp_path: Path) -> Path:
    """MEAS, CTRL, a malformed payload, a foreign UDP port, TCP and ICMP on testbed ports."""
    meas = encode(MsgType.MEAS, MEAS_VALUES, header=Header(5, 100, 500))
    ctrl = encode(MsgType.CTRL, CTRL_VALUES, header=Header(3, 100, 900))
    foreign_udp = udp_frame(TURBINE, 5353, SDC, 53, meas, 1.5)
    tcp = Ether() / IP(src=TURBINE, dst=SDC) / TCP(sport=40000, dport=wire.PORT_SDC) / Raw(meas)
    icmp_error = Ether() / IP(src=SDC, dst=TURBINE) / ICMP(type=3, code=3) / IP(dst=SDC) / UDP(
        sport=40000, dport=wire.PORT_SDC
    ) / Raw(meas)
    frames = [
        udp_frame(TURBINE, 40000, SDC, wire.PORT_SDC, meas, 1.0),
        foreign_udp,
        udp_frame(SDC, 40001, TURBINE, wire.PORT_TURBINE, ctrl, 2.0),
        udp_frame(TURBINE, 40000, SDC, wire.PORT_SDC, meas[:-2], 3.0),
        tcp,
        icmp_error,
    ]
    path = tmp_path / "testbed.pcap"
    wrpcap(str(path), frames)
    return path


def test_read_pcap_returns_testbed_records(capture: Path) -> None:
    records = list(pcap.read_pcap(capture))
    assert [r.time for r in records] == [1.0, 2.0, 3.0]

    meas, ctrl, malformed = records
    assert meas.src == f"{TURBINE}:40000" and meas.dst == f"{SDC}:{wire.PORT_SDC}"
    assert meas.error is None and meas.message is not None
    assert meas.message.type is MsgType.MEAS
    assert meas.message.values == MEAS_VALUES
    assert meas.message.header == Header(5, 100, 500)

    assert ctrl.message is not None and ctrl.message.type is MsgType.CTRL
    assert ctrl.message.values == CTRL_VALUES
    assert ctrl.dst == f"{TURBINE}:{wire.PORT_TURBINE}"

    assert malformed.message is None and malformed.error == "length"


def test_read_pcap_without_header(tmp_path: Path) -> None:
    plain = encode(MsgType.REQUEST, REQUEST_VALUES)
    path = tmp_path / "plain.pcap"
    wrpcap(str(path), [udp_frame(SDC, wire.PORT_CONTROLLER, TURBINE, wire.PORT_TURBINE, plain, 7.0)])
    (record,) = pcap.read_pcap(path, header=False)
    assert record.message is not None and record.message.values == REQUEST_VALUES
    (with_header,) = pcap.read_pcap(path, header=True)
    assert with_header.message is None and with_header.error in {"length", "type"}


def test_scapy_layer_names_fields() -> None:
    payload = encode(MsgType.REQUEST, REQUEST_VALUES, header=Header(8, 1, 2))
    frame = Ether(bytes(udp_frame(SDC, 40000, TURBINE, wire.PORT_CONTROLLER, payload, 0.0)))
    layer = frame[pcap.GTNET]
    assert layer.hdr_seq == 8 and layer.msg_type == MsgType.REQUEST
    body = frame[pcap.BODY_LAYERS[MsgType.REQUEST]]
    assert body.cmd == wire.Command.SET_PARAMS and body.h == 4.0
    assert layer.to_message().values == REQUEST_VALUES
    summary = frame.summary()
    assert "GTNET-SKT #8" in summary
    assert "REQUEST" in summary and "cmd=SET_PARAMS" in summary and "sdc_ip=192.168.0.7" in summary


def test_scapy_layer_flags_rejected_values() -> None:
    bad = encode(MsgType.MEAS, MEAS_VALUES, header=Header(1, 1, 1))[:-4] + b"\x7f\xc0\x00\x00"
    frame = Ether(bytes(udp_frame(TURBINE, 40000, SDC, wire.PORT_SDC, bad, 0.0)))
    assert frame[pcap.GTNET].wire_error() == "nonfinite"
    assert "REJECTED(nonfinite)" in frame.summary()
    assert math.isnan(frame[pcap.BODY_LAYERS[MsgType.MEAS]].omega_meas)


def test_scapy_layer_without_header() -> None:
    payload = encode(MsgType.CTRL, CTRL_VALUES)
    try:
        pcap.bind_gtnet(header=False)
        frame = Ether(bytes(udp_frame(SDC, 40000, TURBINE, wire.PORT_TURBINE, payload, 0.0)))
        assert isinstance(frame[UDP].payload, pcap.GTNETNoHeader)
        assert frame[pcap.GTNETNoHeader].to_message().values == CTRL_VALUES
    finally:
        pcap.bind_gtnet(header=True)
    frame = Ether(bytes(udp_frame(SDC, 40000, TURBINE, wire.PORT_TURBINE, payload, 0.0)))
    assert type(frame[UDP].payload) is pcap.GTNET


def test_cli_prints_lines_and_counts(capture: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert pcap.main([str(capture)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith(f"1.000000 {TURBINE}:40000 -> {SDC}:{wire.PORT_SDC} MEAS #5 wt=101 seq=5")
    assert lines[1].startswith("2.000000") and " CTRL #3 " in lines[1] and "flags=1" in lines[1]
    assert lines[2].endswith("REJECTED length")
    assert lines[3] == "--- 3 datagrams: 2 decoded, 1 rejected"
    assert lines[4].split() == ["MEAS", "1"]
    assert lines[5].split() == ["CTRL", "1"]
    assert lines[6].split() == ["rejected", "length", "1"]
    assert len(lines) == 7


def test_cli_type_filter_and_limit(capture: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert pcap.main([str(capture), "--type", "ctrl"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert len([line for line in out if " CTRL " in line]) == 1
    assert not any(" MEAS " in line or "REJECTED" in line for line in out)

    assert pcap.main([str(capture), "--limit", "1"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("1.000000") and out[1].startswith("--- 1 datagrams")


def test_cli_reports_unreadable_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert pcap.main([str(tmp_path / "missing.pcap")]) == 2
    assert "cannot read" in capsys.readouterr().err
