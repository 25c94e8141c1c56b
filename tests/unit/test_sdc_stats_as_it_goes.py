"""Issue 42 items 7 and 8: an SDC killed with SIGKILL (the timeline's ``kill``) leaves its counts — the
SDC writes its statistics as it goes, not only when it stops — so a turbine's counts after a failover
still add up over both SDCs. A real ``sdvisc sdc --config`` process on the loopback."""

from __future__ import annotations

import json
import signal

import pytest
import yaml

from sdvisc import wire
from tests.unit.test_deployable_services import _start, _stop, _udp, _until
from tests.unit.test_sdc_service_udp import _meas, _request


def _stats(path) -> dict:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return {}


def _start_sdc(tmp_path, out):
    """``sdvisc sdc`` on the loopback, its files in ``out``."""
    cfg = tmp_path / "sdc1.yaml"
    cfg.write_text(yaml.safe_dump({"sdc_id": 1, "step_s": 0.00067, "out_dir": str(out), "bind_ip": "127.0.0.1",
                                   "controller_vip": "127.0.0.1", "realtime_priority": False, "capacity": 4}))
    return _start(["sdc", "--config", str(cfg)], tmp_path)


def test_a_killed_sdc_leaves_the_counts_of_what_it_served(tmp_path):
    try:
        controller = _udp("127.0.0.1", wire.PORT_CONTROLLER)
        turbine = _udp("127.0.0.1", 0)
    except OSError as exc:
        pytest.skip(f"a port is busy on the loopback: {exc}")
    out = tmp_path / "out"
    proc = _start_sdc(tmp_path, out)
    stats_file = out / "sdc1_stats.json"
    sent = 40
    try:
        _until(lambda: (out / "sdc1_ready.json").exists() or proc.poll() is not None, "ready file")
        assert proc.poll() is None, (out / "sdc1.log").read_text()
        sdc = ("127.0.0.1", wire.PORT_SDC)
        controller.sendto(_request(wire.Command.START_INSTANCE, 101, 1), sdc)
        turbine.settimeout(0.2)
        for seq in range(1, sent + 1):
            turbine.sendto(_meas(101, seq), sdc)
        served = _until(lambda: _stats(stats_file).get("turbines", {}).get("wt1_1", {}).get("meas_rx") == sent,
                        "snapshot with every MEAS counted")
        assert served
        proc.send_signal(signal.SIGKILL)  # no chance to write anything at the end
        proc.wait(timeout=30)
    finally:
        _stop(proc)
        controller.close()
        turbine.close()
    stats = json.loads(stats_file.read_text())
    assert stats["final"] is False and stats["sdc_id"] == 1
    row = stats["turbines"]["wt1_1"]
    assert row["meas_rx"] == sent and row["ctrl_tx"] == sent  # one CTRL per MEAS, all counted before the kill
    assert stats["t_written"] >= row["first_meas_rx_t"] > 0


def test_an_sdc_stopped_with_sigterm_replaces_the_snapshot_with_its_full_statistics(tmp_path):
    try:
        controller = _udp("127.0.0.1", wire.PORT_CONTROLLER)
    except OSError as exc:
        pytest.skip(f"the controller port is busy on the loopback: {exc}")
    out = tmp_path / "out"
    proc = _start_sdc(tmp_path, out)
    try:
        _until(lambda: (out / "sdc1_ready.json").exists() or proc.poll() is not None, "ready file")
        controller.sendto(_request(wire.Command.START_INSTANCE, 101, 1), ("127.0.0.1", wire.PORT_SDC))
        _until(lambda: "wt1_1" in _stats(out / "sdc1_stats.json").get("turbines", {}), "snapshot")
    finally:
        code = _stop(proc)
        controller.close()
    assert code == 0
    stats = json.loads((out / "sdc1_stats.json").read_text())
    assert stats["final"] is True and "meas_one_way_ms" in stats["turbines"]["wt1_1"]
    assert not list(out.glob("*.tmp")), "a temporary file of the stats writer was left"
