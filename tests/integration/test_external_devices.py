"""Real devices in the loop, without hardware (issue 29, tests 4a-4c; docs/real-devices.md): an
external GTNET-SKT peer (the project's card emulator in a namespace of its own, attached to the
emulated network through a veth treated as a physical interface) in place of the plant, and an
OpenFlow switch that Mininet did not build (a plain Open vSwitch bridge made with ovs-vsctl, with
its own datapath id) under the SDN app's control. Real Mininet hosts, Open vSwitch, os-ken, UDP."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from sdvisc import wire
from sdvisc.config import CONTROLLER_VIP, CONTROLLER_VMAC
from tests.integration.helpers import ROOT, assert_no_leftovers, run_scenario
from topologies import topos
from topologies.base import describe

pytestmark = pytest.mark.network
SC = ROOT / "scenarios"
K = "4"  # both scenarios' own time scale


def links_of(path: list[str]) -> set[frozenset]:
    return {frozenset(pair) for pair in zip(path, path[1:])}


def test_an_external_switch_carries_the_path_and_its_port_going_down_triggers_dr(tmp_path):
    """s3 of the prototype is a bridge made outside Mininet: the app connects to it, routes wt1_1 over
    it, learns of the failed link l2-s3 from the external switch's own port status (l2 speaks no
    OpenFlow), and after the 40 ms hold reroutes around it; the bridge is gone after the run."""
    s = run_scenario(SC / "external_switch.yaml", tmp_path, "--time-scale", K)
    ext = s["external"]["switches"]["s3"]
    paper = describe(topos["paper"](clusters=1, turbines=2))
    s3_ports = {lk["a_port"] if lk["a"] == "s3" else lk["b_port"] for lk in paper["links"] if "s3" in (lk["a"], lk["b"])}
    s3_ports |= {h["port"] for h in paper["hosts"].values() if h["switch"] == "s3"}
    assert ext["emulated"] and ext["dpid"] == paper["switches"]["s3"]["dpid"]
    assert {int(p) for p in ext["ports"]} == s3_ports  # the topology's port numbers, as the app was told
    assert any(e["type"] == "switch_up" and e.get("switch") == "s3" for e in s["events"])
    assert any(e["type"] == "link_down" and e.get("switch") == "s3" and e.get("source") == "sdn_app"
               for e in s["events"]), "the external switch's own port status did not reach the app"
    (dr,) = [e for e in s["events"] if e["type"] == "dr" and not e.get("after_end")]
    assert frozenset(("l2", "s3")) in links_of(dr["old_path"]) and "s3" not in dr["new_path"]
    (rec,) = s["recoveries"]
    assert rec["cause"] == "dr" and rec["recovery_ms"] is not None and rec["recovery_ms"] < 100
    assert rec["t_detect"] - rec["t_loss"] >= 0.040 - 0.001
    lost_s = rec["recovery_ms"] / 1e3
    assert s["turbines"]["wt1_1"]["packets"]["ctrl_rx"] >= (4.0 - 1.0 - lost_s) / s["step_s"] * 0.95
    assert s["tables"]["T3"]["wt1_1"] == "1/1"
    assert_no_leftovers()


def test_an_external_peer_serves_two_turbines_from_one_ip_through_dr_failover_and_its_own_bad_datagrams(tmp_path):
    """One card, one IP, two UDP ports, native framing: both turbines' MEAS -> CTRL loops close through
    the switches; the card's own bad datagrams (wrong word count, an unknown turbine, a flood) are
    dropped and counted and the other turbines' control goes on; a failed link is repaired by DR for
    both; the killed primary SDC's turbines are taken over by the backup; nothing is left behind."""
    s = run_scenario(SC / "external_peer.yaml", tmp_path, "--time-scale", K)
    card = json.loads((tmp_path / "gtnet_card_stats.json").read_text())
    assert s["external"]["peer"]["emulated"] and s["peer"]["framing"] == "native"
    t1 = s["tables"]["T1"]
    assert t1["wt1_1"]["ip"] == t1["wt1_2"]["ip"] == "10.0.9.1"
    assert (t1["wt1_1"]["udp_port"], t1["wt1_2"]["udp_port"]) == (50101, 50102)
    # the loops: one STREAM_START each, every answer the SDCs sent arrived, nothing of theirs refused
    assert card["totals"]["commands_rx"] == 2 and card["totals"]["rejected_total"] == 0
    for wt, start in (("wt1_1", 1.0), ("wt1_2", 1.2)):
        p = s["turbines"][wt]["packets"]
        lost_s = sum(r["recovery_ms"] for r in s["recoveries"] if r["wt"] == wt) / 1e3
        assert p["meas_tx"] >= (4.0 - start) / s["step_s"] * 0.97
        assert p["ctrl_rx"] >= (4.0 - start - lost_s) / s["step_s"] * 0.95
        assert card["turbines"][wt]["fallbacks"] == 0 and card["turbines"][wt]["trips"] == 0
        assert card["turbines"][wt]["mode"] == "remote"
        # the card's bad datagrams (1.6-1.7 s) interrupted nobody's control
        assert not [g for g in s["turbines"][wt]["ctrl_gaps"] if 1.55 <= g[0] <= 1.95], s["turbines"][wt]["ctrl_gaps"]
    # ... and were counted (the backup SDC got the mirrored copies; the primary's, up to its last snapshot)
    assert card["turbines"]["wt1_2"]["misbehaved_tx"] == 40 and card["turbines"]["wt1_1"]["misbehaved_tx"] == 300
    bad = s["rejected"]["sdc2"]
    assert bad.get("length") == 20 and bad.get("unserved") == 20
    assert bad.get("inconsistent", 0) >= 100  # copies of a sample already taken, with other values
    # DR for both on the failed link, then the backup SDC for both
    causes = sorted((r["wt"], r["cause"]) for r in s["recoveries"])
    assert causes == [("wt1_1", "dr"), ("wt1_1", "sdc_failover"), ("wt1_2", "dr"), ("wt1_2", "sdc_failover")]
    assert all(r["recovery_ms"] is not None and r["recovery_ms"] < 100 for r in s["recoveries"])
    for wt in ("wt1_1", "wt1_2"):
        assert s["turbines"][wt]["per_sdc"]["sdc2"]["meas_rx"] > 0.5 / s["step_s"]  # the last second, from sdc2
        assert s["tables"]["T3"][wt] == "1/1"
    assert_no_leftovers()


def test_fast_failover_groups_on_an_external_switch_repair_in_the_data_plane(tmp_path):
    """The same external s3 with fast-failover groups (sdn.fast_failover) and the failed link s1-s3,
    whose ends are a Mininet switch and the external one: the groups (on both) carry wt1_1 over the
    detour at once — no DR, an interruption far below the 40 ms hold."""
    text = (SC / "external_switch.yaml").read_text()
    text = text.replace("reroute_on_port_status: false}", "fast_failover: true}").replace(
        "{t: 2.0, do: link_down, a: l2, b: s3}", "{t: 2.0, do: link_down, a: s1, b: s3}")
    path = tmp_path / "external_switch_ff.yaml"
    path.write_text(text)
    s = run_scenario(path, tmp_path / "out", "--time-scale", K)
    assert s["sdn_counters"].get("ff_groups", 0) >= 2 and s["openflow"].get("tx_OFPGroupMod", 0) >= 2
    assert not [e for e in s["events"] if e["type"] == "dr" and not e.get("after_end")]
    (cut,) = [i for i in s["interruptions"] if i["wt"] == "wt1_1" and i["fault"] == "link_down"]
    # None: no pause above two samples at all (a hitless repair)
    assert cut["recovered"] and (cut["interruption_ms"] is None or cut["interruption_ms"] < 20), cut
    assert s["turbines"]["wt1_1"]["packets"]["ctrl_rx"] >= 3.0 / s["step_s"] * 0.97
    assert_no_leftovers()


# ------------------------------------------------------------------ a real card: one the run did not start

CARD_NS, RUN_END, CARD_END = "rtdslab42", "rcard0", "rcard1"  # no name the run's clean-up takes for its own
CARD_IP, CARD_MAC = "10.0.9.1", "02:00:00:00:09:01"


def _sh(*args: str, check: bool = True) -> None:
    subprocess.run(args, check=check, capture_output=True, timeout=60)


def _start_card_by_hand(tmp_path: Path) -> subprocess.Popen:
    """As a lab would: the card's own 'machine' (a namespace behind a veth standing for the cable) with
    static neighbour entries, and the card emulator started from its configuration file, at k = 1."""
    _sh("ip", "link", "add", RUN_END, "type", "veth", "peer", "name", CARD_END)
    _sh("ip", "netns", "add", CARD_NS)
    _sh("ip", "link", "set", CARD_END, "netns", CARD_NS)
    _sh("ip", "-n", CARD_NS, "link", "set", CARD_END, "address", CARD_MAC)
    _sh("ip", "-n", CARD_NS, "addr", "add", f"{CARD_IP}/16", "dev", CARD_END)
    for intf in (CARD_END, "lo"):
        _sh("ip", "-n", CARD_NS, "link", "set", intf, "up")
    _sh("ip", "link", "set", RUN_END, "up")
    _sh("ip", "netns", "exec", CARD_NS, "ethtool", "-K", CARD_END, "tx", "off")  # the userspace datapath needs it
    hosts = describe(topos["paper"](clusters=1, turbines=2))["hosts"]
    for ip, mac in [(h["ip"], h["mac"]) for h in hosts.values() if h["role"] != "turbine"] + [(CONTROLLER_VIP,
                                                                                            CONTROLLER_VMAC)]:
        _sh("ip", "-n", CARD_NS, "neigh", "replace", ip, "lladdr", mac, "dev", CARD_END, "nud", "permanent")
    cfg = tmp_path / "card.yaml"
    cfg.write_text(yaml.safe_dump({
        "time_scale": 1.0, "clock_epoch": 0.0, "step_s": 0.00067, "out_dir": str(tmp_path / "card"), "bind_ip": CARD_IP,
        "framing": "native", "sdc": {"ip": hosts["sdc1"]["ip"], "port": wire.PORT_SDC},
        "remote_loss_fallback_s": 0.1, "turbines": [{"name": "wt1_1", "wid": 101, "port": 50101},
                                                    {"name": "wt1_2", "wid": 102, "port": 50102}]}))
    card = subprocess.Popen(["ip", "netns", "exec", CARD_NS, sys.executable, "-m", "scenarios.cli", "gtnet-card",
                             "--config", str(cfg)], cwd=ROOT, start_new_session=True, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    deadline = time.time() + 120
    while not (tmp_path / "card" / "gtnet_card_ready.json").exists():
        assert card.poll() is None and time.time() < deadline, "the card emulator did not come up"
        time.sleep(0.05)
    return card


def test_a_real_card_started_by_hand_leaves_the_run_time_recoveries_and_every_sdcs_counts(tmp_path):
    """Issue 42 item 8: the card emulator started by hand in a namespace of its own, the run given
    ``plant.peer: {emulate: false, interface: <the veth>}`` at k = 1, as with an RTDS: the run counts the
    card's side from the capture on that interface (MEAS, CTRL, AKs: the card's own counts to compare),
    finds the DR and the SDC failover in it, keeps the killed sdc1's counts, and says n/a for the steps."""
    text = (SC / "external_peer.yaml").read_text().replace("time_scale: 4", "time_scale: 1")
    text = text.split("    misbehave:")[0] + f"    emulate: false\n    interface: {RUN_END}\nsdc:" + text.split("\nsdc:")[1]
    path = tmp_path / "real_card.yaml"
    path.write_text(text)
    card = None
    try:
        card = _start_card_by_hand(tmp_path)
        s = run_scenario(path, tmp_path / "out", "--time-scale", "1")
    finally:
        if card is not None:
            card.send_signal(signal.SIGTERM)
            try:
                card.wait(timeout=30)
            except subprocess.TimeoutExpired:
                card.kill()
        _sh("ip", "netns", "del", CARD_NS, check=False)
        _sh("ip", "link", "del", RUN_END, check=False)
    own = json.loads((tmp_path / "card" / "gtnet_card_stats.json").read_text())["turbines"]
    assert not (tmp_path / "out" / "gtnet_card_stats.json").exists()  # the run read nothing of the card's
    assert s["steps"] is None and s["peer"]["emulated"] is False and RUN_END in s["peer"]["counted_at"]
    step = s["step_s"]
    for wt, start in (("wt1_1", 1.0), ("wt1_2", 1.2)):
        row = s["turbines"][wt]
        p = row["packets"]
        # time from the run's clock: control from just after the visc_on of the timeline to the end
        assert start < row["first_ctrl_rx_t"] < start + 0.5, row["first_ctrl_rx_t"]
        assert 4.0 - 0.2 < row["last_ctrl_rx_t"] < 4.5
        # the cable's counts against the card's own (every CTRL it received went over the cable)
        assert own[wt]["ctrl_rx"] * 0.99 <= p["ctrl_rx"] <= own[wt]["ctrl_rx"]
        assert p["meas_tx"] >= (4.0 - start - 0.5) / step and p["ak_tx"] > 0
        assert row["ak_stream"]["card_ctrl_rx"] <= own[wt]["ctrl_rx"]
        # both SDCs' counts, sdc1's up to its last snapshot before the kill at 3 s
        assert set(row["per_sdc"]) == {"sdc1", "sdc2"}
        assert row["per_sdc"]["sdc1"]["ctrl_tx"] > 1.0 / step and row["per_sdc"]["sdc2"]["ctrl_tx"] > 0.5 / step
        as_of = s["sdc_stats_partial"]["sdc1"]["as_of_t"]
        not_counted = (3.0 - as_of) / step + 0.05 / step  # sdc1's last moments, and CTRL in flight
        assert p["ctrl_tx_sdc"] == sum(r["ctrl_tx"] for r in row["per_sdc"].values())
        assert p["ctrl_rx"] - not_counted <= p["ctrl_tx_sdc"], (p, as_of)
    assert s["sdc_stats_partial"]["sdc1"]["why"] == "killed" and 2.0 < s["sdc_stats_partial"]["sdc1"]["as_of_t"] <= 3.0
    # DR for both on the failed link, then the backup SDC for both: found in the capture
    causes = sorted((r["wt"], r["cause"]) for r in s["recoveries"])
    assert causes == [("wt1_1", "dr"), ("wt1_1", "sdc_failover"), ("wt1_2", "dr"), ("wt1_2", "sdc_failover")], causes
    assert all(r["recovery_ms"] is not None and r["recovery_ms"] < 150 for r in s["recoveries"]), s["recoveries"]
    assert {(i["wt"], i["fault"]) for i in s["interruptions"] if i["recovered"]} >= {
        (wt, f) for wt in ("wt1_1", "wt1_2") for f in ("link_down", "kill")}
    assert_no_leftovers()
