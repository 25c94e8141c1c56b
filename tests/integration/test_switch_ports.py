"""AF_XDP switch ports on real Mininet + Open vSwitch (scenarios/switch_ports.py): a link failure
recovered by DR as with system ports, every port of the run opened as AF_XDP (or, where this
machine's Open vSwitch refuses AF_XDP, all back to system ports with the refusal recorded), and
no PMD thread or port left after the run."""

from __future__ import annotations

import subprocess

import pytest

from tests.integration.helpers import ROOT, assert_no_leftovers, run_scenario

pytestmark = pytest.mark.network
SC = ROOT / "scenarios"


def _pmd_threads() -> list[str]:
    pid = subprocess.run(["pidof", "ovs-vswitchd"], capture_output=True, text=True).stdout.split()[0]
    tasks = subprocess.run(["ps", "-L", "-o", "comm=", "-p", pid], capture_output=True, text=True).stdout.split()
    return [t for t in tasks if t.startswith("pmd")]


def test_link_failure_is_recovered_by_dr_on_afxdp_ports(tmp_path):
    s = run_scenario(SC / "link_failure_dr.yaml", tmp_path, "--switch-ports", "afxdp")
    ports = s["switch_ports"]
    assert ports["requested"] == "afxdp" and ports["ports"] >= 4
    assert ports["used"] == "afxdp" or (ports["used"] == "system" and ports["refused"]), ports
    (rec,) = s["recoveries"]
    assert rec["cause"] == "dr" and rec["recovery_ms"] is not None and rec["recovery_ms"] < 100
    p = s["turbines"]["wt1_1"]["packets"]
    assert p["ctrl_rx"] >= 0.9 * p["meas_tx"]
    assert _pmd_threads() == []  # the bridges are gone, and their PMD thread with them
    assert_no_leftovers()
