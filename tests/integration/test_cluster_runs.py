"""Scenarios across two servers (issue 30; scenarios/cluster_*.yaml, docs/cluster.md): the stand-in
servers are made by the run (namespaces with their own sshd and Open vSwitch, reached over ssh as real
machines), the switches and SDCs run on them, the turbines, plant, SDN app and OWFCC on this machine,
every link between two places a VXLAN tunnel. Packet counts, recoveries and the clean-up checked as
for the one-machine scenarios (tests/integration/test_smoke_run.py, test_sdn_scenarios.py)."""

from __future__ import annotations

import pytest

from host_tools import servers
from tests.integration.helpers import ROOT, assert_no_leftovers, run_scenario

pytestmark = pytest.mark.network

SC = ROOT / "scenarios"
PLACED = {"s1": "srv1", "s4": "srv1", "sdc1": "srv1", "s2": "srv2", "s3": "srv2", "sdc2": "srv2",
          "wt1_1": "head", "l2": "head", "owfcc": "head"}


def ctrl_after(s: dict, t: float) -> bool:
    return s["turbines"]["wt1_1"]["last_ctrl_rx_t"] > t


def assert_placed_and_tunnelled(s: dict, alive=("srv1", "srv2"), sdc="sdc1") -> None:
    cluster = s["cluster"]
    assert set(cluster["servers"]) == {"srv1", "srv2"} and all(v["emulated"] for v in cluster["servers"].values())
    assert {n: cluster["placement"][n] for n in PLACED} == PLACED
    tunnels = {frozenset((t["a"], t["b"])) for t in cluster["tunnels"]}
    # the switch links between the servers and every link from the head to a switch are tunnels
    assert {frozenset(p) for p in (("s1", "s2"), ("s1", "s3"), ("s3", "s4"), ("l2", "s3"), ("l2", "s4"),
                                   ("owfcc", "s1"))} <= tunnels
    assert frozenset(("s1", "s4")) not in tunnels and frozenset(("s2", "s3")) not in tunnels
    assert len({t["vni"] for t in cluster["tunnels"]}) == len(cluster["tunnels"])  # one VNI per link
    # the switches' Open vSwitch daemons are the servers' own: their CPU is counted apart
    # (the CPU of a server alive at the end; a lost one's cannot be read then)
    assert {*(f"ovs-vswitchd@{n}" for n in alive), f"{sdc}.sdc", "plant", "controller"} <= set(s["cpu"]), s["cpu"]


def test_smoke_across_two_servers(tmp_path):
    s = run_scenario(SC / "cluster_smoke.yaml", tmp_path)
    assert s["completed"]
    assert_placed_and_tunnelled(s)
    wt = s["turbines"]["wt1_1"]
    packets = wt["packets"]
    expected = (3.0 - 1.0) / s["step_s"]
    assert packets["meas_tx"] == pytest.approx(expected, rel=0.02)
    assert packets["ctrl_rx"] == pytest.approx(expected, rel=0.02), packets
    assert packets["meas_rx_sdc"] >= 0.98 * packets["meas_tx"]
    assert packets["ctrl_tx_sdc"] >= 0.98 * packets["meas_rx_sdc"]
    assert wt["first_meas_tx_t"] >= 1.0 and wt["first_ctrl_rx_t"] >= 1.0
    assert list(s["turbines"]) == ["wt1_1"] and s["recoveries"] == []
    assert s["cluster"]["lost"] == {}
    assert_no_leftovers()
    assert servers.server_netns() == [] and servers.lan_netns() == [] and servers.key_dirs() == []


def test_a_failed_tunnel_is_repaired_by_dr(tmp_path):
    s = run_scenario(SC / "cluster_link_failure_dr.yaml", tmp_path, "--time-scale", "4")
    assert_placed_and_tunnelled(s)
    (rec,) = s["recoveries"]
    assert rec["wt"] == "wt1_1" and rec["cause"] == "dr"
    assert rec["fault"]["a"] == "s1" and rec["fault"]["b"] == "s3"  # the tunnel between the servers
    assert rec["recovery_ms"] is not None and 0 < rec["recovery_ms"] < 100
    assert rec["t_detect"] - rec["t_loss"] >= 0.040 - 0.001  # never before the 40 ms hold
    assert ctrl_after(s, 3.9)
    lost_s = rec["recovery_ms"] / 1e3
    assert s["turbines"]["wt1_1"]["packets"]["ctrl_rx"] >= (4.0 - 1.0 - lost_s) / s["step_s"] * 0.97
    dr = [e for e in s["events"] if e["type"] == "dr" and not e.get("after_end")]
    assert len(dr) == 1
    new_links = [frozenset(p) for p in zip(dr[0]["new_path"], dr[0]["new_path"][1:])]
    assert frozenset(("s1", "s3")) not in new_links
    assert_no_leftovers()


def test_the_loss_of_a_server_is_survived_by_sdc_failover(tmp_path):
    s = run_scenario(SC / "cluster_server_loss.yaml", tmp_path, "--time-scale", "4")
    assert_placed_and_tunnelled(s, alive=("srv2",), sdc="sdc2")
    assert "ovs-vswitchd@srv1" not in s["cpu"] and "sdc1.sdc" not in s["cpu"]
    assert list(s["cluster"]["lost"]) == ["srv1"]
    (rec,) = s["recoveries"]
    assert rec["fault"]["type"] == "server_down" and sorted(rec["fault"]["nodes"]) == ["s1", "s4", "sdc1"]
    assert rec["cause"] == "sdc_failover" and rec["recovery_ms"] is not None and rec["recovery_ms"] < 100
    w = s["turbines"]["wt1_1"]
    assert w["per_sdc"]["sdc2"]["ctrl_tx"] > 0.9 * (4.0 - 2.0) / s["step_s"]
    assert ctrl_after(s, 3.9)
    failover = [e for e in s["events"] if e["type"] == "sdc_failover"]
    assert failover and failover[0]["backup"] == "sdc2"
    # the lost server's SDC died with it: not restarted, not counted as a crash
    assert s["processes_killed"] == ["sdc1.sdc"] and s["processes_exited_early"] == {}
    assert_no_leftovers()


def test_fast_failover_groups_repair_a_failed_tunnel_in_the_data_plane(tmp_path):
    """link_failure_ff across the servers: the watch port of s3's group is the tunnel's VXLAN device,
    set down on both machines; the switches move wt1_1's traffic before any DR hold ends."""
    path = tmp_path / "cluster_link_failure_ff.yaml"
    path.write_text((SC / "cluster_link_failure_dr.yaml").read_text().replace(
        "sdn: {dr_hold_s: 0.040, dynamic_routing: true, reroute_on_port_status: false}",
        "sdn: {dr_hold_s: 0.040, dynamic_routing: true, fast_failover: true}").replace(
        "name: cluster_link_failure_dr", "name: cluster_link_failure_ff"))
    s = run_scenario(path, tmp_path / "out")
    assert_placed_and_tunnelled(s)
    fault = next(e for e in s["events"] if e["type"] == "link_down" and e["source"] == "timeline")
    (rec,) = [r for r in s["interruptions"] if r["wt"] == "wt1_1"]
    assert rec["recovered"] and rec["t_fault"] == pytest.approx(fault["t_effective"])
    assert (rec["interruption_ms"] or 0.0) < 40.0, rec  # below the DR hold: the data plane repaired it
    assert not [e for e in s["events"] if e["type"] == "dr" and e["source"] == "sdn_app" and not e.get("after_end")]
    assert s["openflow"]["tx_OFPGroupMod"] >= 2
    assert ctrl_after(s, 3.9)
    assert_no_leftovers()
