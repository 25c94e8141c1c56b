"""AF_XDP switch ports on real Mininet + Open vSwitch (scenarios/switch_ports.py): a link failure
recovered by DR as with system ports, every port of the run opened as AF_XDP (or, where this
machine's Open vSwitch refuses AF_XDP, all back to system ports with the refusal recorded), and
no PMD thread or port left after the run."""

from __future__ import annotations

import subprocess

import pytest
import yaml

from sdvisc.config import CONTROLLER_VIP, CONTROLLER_VMAC
from tests.integration.helpers import ROOT, assert_no_leftovers, run_scenario
from topologies import topos

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


def test_a_patch_link_fails_and_returns_like_a_veth(tmp_path):
    """switch_links: patch (scenarios/switch_links.py): s1-s3 is a pair of patch ports, removed at
    2 s and restored at 3 s. The SDN app sees the link go and come back, the fast-failover group
    repairs the failure in the data plane (no DR), control carries on after the return, and the
    run leaves no bridge or port behind."""
    sc = yaml.safe_load((SC / "link_failure_ff.yaml").read_text())
    sc["name"] = "patch_link_ff"
    sc["switch_links"] = "patch"
    sc["timeline"].append({"t": 3.0, "do": "restore_links"})
    path = tmp_path / "patch.yaml"
    path.write_text(yaml.safe_dump(sc))
    s = run_scenario(path, tmp_path / "out")
    assert s["switch_links"] == "patch"
    topo = topos["paper"](clusters=1, turbines=2)  # as in link_failure_ff.yaml
    topo.add_intake(CONTROLLER_VIP, CONTROLLER_VMAC)  # and the SDN app's intake host (docs/sdn.md)
    assert s["switch_ports"]["ports"] == len(topo.hosts())  # only the hosts' links are veths
    seen = [(e["type"], sorted(e["link"])) for e in s["events"]
            if e.get("source") == "sdn_app" and e["type"] in ("link_down", "link_up")]
    assert seen == [("link_down", ["s1", "s3"]), ("link_up", ["s1", "s3"])]
    (rec,) = [r for r in s["interruptions"] if r["wt"] == "wt1_1"]
    assert rec["recovered"] and (rec["interruption_ms"] or 0.0) < 40.0, rec
    assert not [e for e in s["events"] if e["type"] == "dr" and e["source"] == "sdn_app" and not e.get("after_end")]
    assert s["turbines"]["wt1_1"]["last_ctrl_rx_t"] > 3.9
    assert_no_leftovers()
