"""The plant service's shim (plant.service) end to end on loopback, without Mininet: its process
binds the turbine's socket, streams after STREAM_START, applies the answers, reports AKs, takes
stdin's events and stops on ``stop``, then writes plant_stats.json, timeseries.csv and the live
files. The core's behaviour is tested in test_plant_core.py; this only checks the wiring."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from sdvisc import wire
from sdvisc.config import PlantConfig, write_config

ROOT = Path(__file__).resolve().parents[2]
TURBINE, SDC, VIP = "127.0.0.2", "127.0.0.3", "127.0.0.4"


def bound(ip: str, port: int) -> socket.socket:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        sock.bind((ip, port))
    except OSError as exc:
        sock.close()
        pytest.skip(f"cannot bind {ip}:{port}: {exc}")
    sock.settimeout(0.05)
    return sock


def request(cmd: int) -> bytes:
    values = {"req_id": 1, "cmd": int(cmd), "wt": 101, "sdc_ip": wire.ip_to_i32(SDC), "mask": 0, "h": 0.0, "d": 0.0,
              "m_q": 0.0, "v_ref": 0.0, "q_ref": 0.0, "supp": 0}
    return wire.encode(wire.MsgType.REQUEST, values, header=wire.Header(1, 0, 0))


def answer(meas: wire.Message) -> bytes:
    seq = meas["seq"]
    values = {"wt": 101, "seq": seq, "meas_seq": seq, "v_ref_d": 1.0, "v_ref_q": 0.0, "i_ref_d": 0.5, "i_ref_q": 0.0,
              "delta": 0.1, "omega": 1.0, "e_mag": 1.0, "flags": 0}
    return wire.encode(wire.MsgType.CTRL, values, header=wire.Header(seq, meas.header.sec, meas.header.nsec))


def test_the_service_process_streams_answers_reports_and_stops_on_stdin(tmp_path):
    sdc, controller = bound(SDC, wire.PORT_SDC), bound(VIP, wire.PORT_CONTROLLER)
    cfg = PlantConfig(duration_s=None, turbines=[{"name": "wt1_1", "wid": 101, "ip": TURBINE}], out_dir=str(tmp_path),
                      step_s=0.002, controller_vip=VIP, record=["wt1_1"], realtime_priority=False)
    path = write_config(cfg, tmp_path / "plant_config.json")
    proc = subprocess.Popen([sys.executable, "-m", "plant.service", "--config", str(path)], cwd=ROOT,
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        answered, deadline = 0, time.monotonic() + 30
        while answered < 100 and time.monotonic() < deadline and proc.poll() is None:
            if not answered:  # until the socket is bound and the stream runs
                controller.sendto(request(wire.Command.STREAM_START), (TURBINE, wire.PORT_TURBINE))
            try:
                data, addr = sdc.recvfrom(2048)
            except (TimeoutError, ConnectionRefusedError):
                continue
            meas = wire.decode(data, header=True)
            assert meas.type == wire.MsgType.MEAS and addr == (TURBINE, wire.PORT_TURBINE)
            sdc.sendto(answer(meas), addr)
            answered += 1
        assert answered == 100, proc.poll()
        proc.stdin.write(json.dumps({"type": "load_step", "mw": 1.0}) + "\n" + json.dumps({"type": "stop"}) + "\n")
        proc.stdin.flush()
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        sdc.close()
    assert proc.returncode == 0, proc.stderr.read()
    aks = []
    while True:
        try:
            aks.append(wire.decode(controller.recvfrom(2048)[0], header=True))
        except TimeoutError:
            break
    controller.close()
    stats = json.loads((tmp_path / "plant_stats.json").read_text())
    counts = stats["turbines"]["wt1_1"]
    assert counts["meas_tx"] >= 100 and counts["ctrl_rx"] >= 90 and counts["requests_rx"] >= 1
    assert counts["ak_tx"] >= 1 and {ak["ak"] for ak in aks} >= {1} and all(ak.type == wire.MsgType.AK for ak in aks)
    kinds = [e["type"] for e in stats["events"]]
    assert kinds[0] == "stream_start" and "ctrl_started" in kinds and kinds[-2:] == ["load_step", "stop"]
    assert stats["steps"] >= 100 and stats["cpu_s"] > 0
    assert [json.loads(line)["type"] for line in (tmp_path / "plant_events.jsonl").read_text().splitlines()] == kinds
    assert json.loads((tmp_path / "plant_status.json").read_text())["streaming"] == ["wt1_1"]
    assert (tmp_path / "timeseries.csv").read_text().startswith("t,v_pcc,f_pcc_hz,wt1_1.p")
