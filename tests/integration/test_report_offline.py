"""``python -m report --quick --only F6`` end to end (offline: no network, no root): the page, the
claims and the figures are written, and every claim of the experiment has a computed row.

Marked slow (the whole module): report runs in child processes, F6's offline simulation among them,
not pure unit tests."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tests.integration.helpers import ROOT

pytestmark = pytest.mark.slow


def test_quick_report_of_one_offline_experiment(tmp_path):
    out = tmp_path / "report"
    res = subprocess.run([sys.executable, "-m", "report", "--quick", "--only", "F6", "--out", str(out)], cwd=ROOT,
                         capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "[1/1] F6" in res.stdout and "F6 ok in" in res.stdout  # the progress lines
    data = json.loads((out / "claims.json").read_text())
    assert [e["id"] for e in data["experiments"]] == ["F6"] and data["experiments"][0]["status"] == "ok"
    rows = data["claims"]
    assert [r["id"] for r in rows] == ["F6.a", "F6.b", "F6.c", "F6.d", "F6.e"]
    for r in rows:
        assert r["verdict"] in ("yes", "partly", "no") and r["paper"] and r["command"].endswith("--only F6 --quick")
        assert r["testbed"] not in ("", "—") and r["measured"], r
        assert r["verdict"] == "yes" or r["reason"], r
    # computed, not typed: the SDViSC's current limit is the law's i_max (1.5 p.u.)
    assert abs(rows[2]["measured"]["i_visc_max"] - 1.5) < 0.05
    assert data["machine"]["before"]["cpu_count"] >= 1 and len(data["machine"]["before"]["load_average"]) == 3
    html = (out / "index.html").read_text()
    assert html.count("data:image/png;base64,") == 1 and "F6.e" in html and "load average" in html
    for ext in ("png", "svg"):
        assert (out / f"f6_short_circuit.{ext}").stat().st_size > 5000


def test_sdvisc_report_runs_the_report_as_a_child(tmp_path):
    res = subprocess.run([sys.executable, "-m", "scenarios.cli", "report", "--list", "--only", "C2,f7"], cwd=tmp_path,
                         capture_output=True, text=True, timeout=120,
                         env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})
    assert res.returncode == 0, res.stderr
    assert "C2.a" in res.stdout and "F7.a" in res.stdout and "F1.a" not in res.stdout
