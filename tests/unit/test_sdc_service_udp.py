"""The SDC service over real UDP sockets on the loopback interface (no Mininet): commands, one
CTRL per usable MEAS, the sequence-number policy and the rejection of malformed packets."""

from __future__ import annotations

import json
import socket
import struct
import threading
import time

import numpy as np
import pytest

from sdc_unit.service import SdcService
from sdc_unit.service import main as service_main
from sdvisc import wire
from sdvisc.config import SdcConfig


def _meas(wt, seq, vd=1.0, p=0.5):
    values = {"wt": wt, "seq": seq, "t_sim": seq * 0.00067, "v_d": vd, "v_q": 0.05, "i_d": p, "i_q": -0.1,
              "p": p * vd, "q": 0.1, "v_dc": 1.0, "omega_meas": 1.0}
    return wire.encode(wire.MsgType.MEAS, values, header=wire.Header(seq, int(time.time()), 0))


def _request(cmd, wt, req_id):
    values = {"req_id": req_id, "cmd": int(cmd), "wt": wt, "sdc_ip": wire.ip_to_i32("127.0.0.1"), "mask": 0,
              "h": 0.0, "d": 0.0, "m_q": 0.0, "v_ref": 0.0, "q_ref": 0.0, "supp": 0}
    return wire.encode(wire.MsgType.REQUEST, values, header=wire.Header(req_id, 0, 0))


@pytest.fixture
def turbine_socket():
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        sock.bind(("127.0.0.1", wire.PORT_TURBINE))
    except OSError as exc:
        pytest.skip(f"turbine port busy: {exc}")
    sock.settimeout(0.2)
    yield sock
    sock.close()


def _collect(sock, until_quiet=0.3):
    got = []
    end = time.time() + 3.0
    while time.time() < end:
        try:
            data, _ = sock.recvfrom(2048)
        except TimeoutError:
            if got:
                break
            continue
        got.append(wire.decode(data, header=True))
    return got


def test_service_answers_every_usable_measurement_once(turbine_socket, tmp_path):
    svc = SdcService(SdcConfig(step_s=0.00067, controller_vip="127.0.0.1", bind_ip="127.0.0.1", capacity=8,
                               out_dir=str(tmp_path)))
    worker = threading.Thread(target=svc.run, kwargs={"until": time.time() + 3.0}, daemon=True)
    worker.start()
    try:
        tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        dst = ("127.0.0.1", wire.PORT_SDC)
        tx.sendto(_request(wire.Command.START_INSTANCE, 101, 1), dst)
        tx.sendto(_request(wire.Command.START_INSTANCE, 102, 2), dst)
        time.sleep(0.05)
        wt = turbine_socket  # the turbine sends from the port it listens on: the SDC answers the source
        nan = bytearray(_meas(101, 4))
        struct.pack_into(">f", nan, 4 * (3 + 4), float("nan"))  # v_d := NaN
        for seq in range(1, 4):
            wt.sendto(_meas(101, seq), dst)
            wt.sendto(_meas(102, seq, p=0.3), dst)
        wt.sendto(bytes(nan), dst)  # dropped, counted
        wt.sendto(_meas(101, 2), dst)  # stale: dropped, counted
        after_loss = _meas(101, 6)
        wt.sendto(after_loss, dst)  # 4 and 5 lost
        wt.sendto(_meas(103, 1), dst)  # no instance: not answered
        wt.sendto(b"\x00" * 10, dst)  # malformed
        ctrl = _collect(turbine_socket)
        tx.close()
    finally:
        svc.stop()
        worker.join(timeout=2.0)
    by_wt = {}
    for m in ctrl:
        assert m.type == wire.MsgType.CTRL and np.isfinite([m[k] for k in ("v_ref_d", "v_ref_q", "delta")]).all()
        by_wt.setdefault(m["wt"], []).append(m["meas_seq"])
    assert by_wt == {101: [1, 2, 3, 6], 102: [1, 2, 3]}
    c101 = svc.instances[101].counts
    assert (c101["meas_rx"], c101["ctrl_tx"], c101["meas_stale"], c101["meas_lost"]) == (4, 4, 1, 2)
    # where the loss ended, by the send time of the first MEAS through again (scenarios.interruptions)
    sent = wire.decode(after_loss, header=True).header
    assert svc.instances[101].meas_resumed == [[sent.sec + sent.nsec * 1e-9, 2]]
    assert svc.instances[102].meas_resumed == []
    assert 103 not in svc.instances and svc.rejected["unserved"] == 1  # never told to serve it: no instance
    assert svc.rx_stats.nonfinite == 1 and svc.rx_stats.length == 1
    # the first answer continues the turbine's operating point: v_ref = v + (r_f + j x_f) i (bumpless start)
    first = next(m for m in ctrl if m["wt"] == 101)
    assert first["v_ref_d"] == pytest.approx(1.0 + 0.003 * 0.5 + 0.08 * 0.1, abs=2e-3)


def test_a_bad_config_is_refused_before_anything_starts(tmp_path, capsys):
    cfg = tmp_path / "sdc1_config.json"
    cfg.write_text(json.dumps({"step_s": 0.00067, "out_dir": str(tmp_path), "standby": "lukewarm", "capcity": 8}))
    with pytest.raises(SystemExit) as ended:
        service_main(["--config", str(cfg)])
    assert ended.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("sdc: ")
    assert "standby" in err and "capcity" in err  # every problem named
    assert [p.name for p in tmp_path.iterdir()] == ["sdc1_config.json"]  # no ready file: the runner waits
