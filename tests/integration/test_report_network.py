"""``python -m report --quick --only F6,F1net`` end to end: one physical (offline) and one
cyber-in-the-loop experiment (the four SDViSCs stepped by the SDC over Mininet + Open vSwitch at
the auto time scale): the page, the claims with computed rows, the figures and the network run's
own output, and nothing left behind."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from report import network_runs
from report.network_runs import LOCK_HELD_ENV
from tests.integration.helpers import ROOT, assert_no_leftovers

pytestmark = pytest.mark.network


def test_quick_report_of_one_physical_and_one_cyber_experiment(tmp_path):
    out = tmp_path / "report"
    # the test suite runs one network test at a time: the report need not take the lock itself
    res = subprocess.run([sys.executable, "-m", "report", "--quick", "--only", "F6,F1net", "--out", str(out)], cwd=ROOT,
                         capture_output=True, text=True, timeout=1200, env=dict(os.environ, **{LOCK_HELD_ENV: "1"}))
    assert res.returncode == 0, res.stdout + res.stderr
    data = json.loads((out / "claims.json").read_text())
    assert [(e["id"], e["kind"], e["status"]) for e in data["experiments"]] == [("F6", "offline", "ok"),
                                                                              ("F1net", "cyber", "ok")]
    rows = {r["id"]: r for r in data["claims"]}
    assert set(rows) == {"F6.a", "F6.b", "F6.c", "F6.d", "F6.e", "F1net.a"}
    for r in rows.values():
        assert r["verdict"] in ("yes", "partly", "no") and r["paper"] and r["command"] and r["testbed"] != "—", r
        assert r["verdict"] == "yes" or r["reason"], r
    net = data["experiments"][1]
    k = net["time_scale"]["f1_tustin_vs_hd"]
    assert k in (1, 2, 4, 8, 16, 32, 64)  # chosen by the calibration before t = 0
    summary = json.loads((out / "runs" / "f1_tustin_vs_hd" / "summary.json").read_text())
    # a calibrated run whose own answers came late is run again at twice its k (the first attempt kept)
    again = (net["numbers"].get("run_again") or {}).get("f1_tustin_vs_hd")
    calibrated = json.loads((Path(again["first_attempt"]) / "summary.json").read_text()) if again else summary
    assert calibrated["time"]["calibration"]["turbines"]
    assert network_runs.did_not_hold(calibrated) if again else not network_runs.did_not_hold(summary)
    assert summary["time"]["time_scale"] == k == calibrated["time"]["calibration"]["time_scale"] * (2 if again else 1)
    ports = summary["switch_ports"]  # the report's default: AF_XDP, or system ports where refused, with the reason
    assert ports["requested"] == "afxdp" and (ports["used"] == "afxdp" or ports["refused"]), ports
    # computed from the run: the SDC through the network follows the HD ViSC (full report: 1.01 % RMS of the
    # range; a run that lost control or tripped is tens of %), and the SDViSCs got CTRL
    assert 0.0 < rows["F1net.a"]["measured"]["worst_pct"] < 10.0, rows["F1net.a"]["measured"]
    for wt in ("wt1_1", "wt2_1", "wt3_1", "wt4_1"):
        assert summary["turbines"][wt]["packets"]["ctrl_rx"] > 0.9 * (summary["duration_s"] - 0.2) / summary["step_s"]
    html = (out / "index.html").read_text()
    assert html.count("data:image/png;base64,") == 2 and "F1net.a" in html and "k = " in html
    for name in ("f6_short_circuit", "f1net_network_vs_hd"):
        for ext in ("png", "svg"):
            assert (out / f"{name}.{ext}").stat().st_size > 5000
    assert_no_leftovers()
