"""The SDN application's paper experiments on real Mininet + Open vSwitch + os-ken (Figs. 19, 22–24)."""

from __future__ import annotations

import json
import subprocess
import sys
import time

import pytest

from tests.integration.helpers import ROOT, assert_no_leftovers, run_scenario, time_scale_args

pytestmark = pytest.mark.network
SC = ROOT / "scenarios"


def packets(summary, wt="wt1_1"):
    return summary["turbines"][wt]["packets"]


def ctrl_after(summary, t, wt="wt1_1"):
    """Control packets the turbine received after time t (from its last packet time and gaps)."""
    w = summary["turbines"][wt]
    return w["last_ctrl_rx_t"] is not None and w["last_ctrl_rx_t"] > t


def test_link_failure_with_dr_reroutes_within_100_ms(tmp_path):
    """One failure, one DR, the new path avoids the failed link. At time scale 4: under the one-core
    load at k = 2 the plant (SCHED_FIFO) fell up to 15 simulated ms behind and the new path carried no
    control for 45 simulated ms 0.26 s after the reroute (2.9 % late steps: the run's own advice said
    to take a larger k), and the app rerouted a second time — as designed, on the turbine's report of
    40 ms without control. A machine's stall, not the network model's behaviour."""
    s = run_scenario(SC / "link_failure_dr.yaml", tmp_path, "--time-scale", "4")
    (rec,) = s["recoveries"]
    assert rec["wt"] == "wt1_1" and rec["cause"] == "dr"
    assert rec["recovery_ms"] is not None and 0 < rec["recovery_ms"] < 100
    # never before the 40 ms hold, counted (as the app does) from the turbine's last control packet
    assert rec["t_detect"] - rec["t_loss"] >= 0.040 - 0.001
    assert ctrl_after(s, 3.9)
    lost_s = rec["recovery_ms"] / 1e3
    assert packets(s)["ctrl_rx"] >= (4.0 - 1.0 - lost_s) / s["step_s"] * 0.97
    dr = [e for e in s["events"] if e["type"] == "dr" and not e.get("after_end")]
    assert len(dr) == 1 and ["s1", "s3"] not in [sorted(p) for p in zip(dr[0]["new_path"], dr[0]["new_path"][1:])]
    assert s["tables"]["T3"]["wt1_1"] == "1/1"
    assert_no_leftovers()


def test_link_failure_without_dr_stops_control_packets(tmp_path):
    s = run_scenario(SC / "link_failure_no_dr.yaml", tmp_path)
    (rec,) = s["recoveries"]
    assert rec["recovery_ms"] is None and rec["t_restored"] is None
    assert not ctrl_after(s, 2.2)
    assert packets(s)["ctrl_rx"] == pytest.approx(1.0 / s["step_s"], rel=0.05)  # only from 1 s to 2 s
    assert any(e["type"] == "dr_not_acted" for e in s["events"])
    assert s["tables"]["T3"]["wt1_1"].startswith("0/")


def test_sdc_failover_backup_takes_over_bumplessly(tmp_path):
    s = run_scenario(SC / "sdc_failover.yaml", tmp_path)
    (rec,) = s["recoveries"]
    assert rec["cause"] == "sdc_failover" and rec["recovery_ms"] is not None and rec["recovery_ms"] < 100
    w = s["turbines"]["wt1_1"]
    assert w["per_sdc"]["sdc2"]["ctrl_tx"] > 0.9 * (4.0 - 2.0) / s["step_s"]
    assert ctrl_after(s, 3.9)
    assert w["takeover_jump_pu"] is not None and w["takeover_jump_pu"] < 0.05  # no jump above 5 % of rating
    assert s["processes_killed"] == ["sdc1.sdc"] and s["processes_exited_early"] == {}


def test_sdc_failover_off_no_backup_packets(tmp_path):
    s = run_scenario(SC / "sdc_failover_off.yaml", tmp_path)
    (rec,) = s["recoveries"]
    assert rec["recovery_ms"] is None
    assert s["turbines"]["wt1_1"]["per_sdc"].get("sdc2", {}).get("ctrl_tx", 0) == 0
    assert not ctrl_after(s, 2.2)
    assert any(e["type"] == "failover_unavailable" for e in s["events"])


def test_plug_and_play_packets_only_after_each_request(tmp_path):
    s = run_scenario(SC / "plug_and_play.yaml", tmp_path)
    assert set(s["turbines"]) == {"wt1_1", "wt4_1"}
    for wt, t_req, duration in (("wt1_1", 1.2, 6.0 - 1.2), ("wt4_1", 4.8, 6.0 - 4.8)):
        w = s["turbines"][wt]
        assert w["first_meas_tx_t"] >= t_req and w["per_sdc"]["sdc1"]["first_meas_rx_t"] >= t_req
        # generous: 7 userspace bridges and 53 hosts on 2 cores add delay and some loss
        assert 0.8 * duration / s["step_s"] <= w["packets"]["ctrl_rx"] <= 1.01 * duration / s["step_s"]
    # no other turbine of the 50 ever exchanged a packet with an SDC
    assert s["topology"]["hosts"] == 53
    assert s["tables"]["T2"]["wt4_1"] == "1/1" and s["tables"]["T2"]["wt2_1"] == "0/1"
    # event-based: no polling — each request costs the switches a handful of messages, whatever the
    # run's wall time (farm compact: 6 flow-mods, 3 packet-outs, 3 other on average; issue 42: the total,
    # keepalives and reconnections included, grew with the time scale and failed under load)
    per = s["openflow"]["per_request"]
    assert per["requests"] == 2
    assert per["flow_mods"] <= 10 and per.get("packet_outs", 0) <= 5 and per.get("other", 0) <= 5, per
    assert set(s["openflow"]["keepalive"]) == {"echo_requests_rx", "switch_connects"}  # reported apart


def test_cli_link_down_triggers_the_same_recovery(tmp_path):
    # a copy of the DR scenario without its timeline fault: the failure comes from the CLI
    scenario = tmp_path / "cli.yaml"
    scenario.write_text((SC / "link_failure_dr.yaml").read_text().replace(
        "  - {t: 2.0, do: link_down, a: s1, b: s3}\n", "").replace("duration_s: 4.0", "duration_s: 10.0"))
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "scenarios.cli", "run", str(scenario), "--out", str(out), "--cli",
                             "--quiet", *time_scale_args()], cwd=ROOT, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    status = out / "plant_status.json"

    def wait_t(t):
        deadline = time.time() + 60
        while time.time() < deadline:
            try:
                if json.loads(status.read_text())["t_sim"] >= t:
                    return
            except (OSError, ValueError, KeyError):
                pass
            time.sleep(0.05)
        raise AssertionError(f"run did not reach t = {t}")

    wait_t(1.5)
    proc.stdin.write("link s1 s3 down\n")
    proc.stdin.flush()
    wait_t(1.8)
    # access control: wt1_2 spoofs wt1_1's IP toward the SDC; 20 garbage datagrams must not get there
    # (the command imports scapy in the host: it takes a few seconds, the CLI waits for it)
    spoof = ("from scapy.all import Ether, IP, UDP, Raw, sendp; "
             "sendp([Ether(src='02:00:00:00:01:02', dst='02:00:00:00:00:15')/IP(src='10.0.1.1', dst='10.0.0.21')"
             "/UDP(sport=50020, dport=50010)/Raw(b'x' * 57)] * 20, iface='wt1_2-eth0', verbose=0)")
    proc.stdin.write(f'wt1_2 {sys.executable} -c "{spoof}"\n')
    proc.stdin.flush()
    # while a host command runs, Mininet's CLI forwards typed input to it: type nothing until it ended
    deadline = time.time() + 60
    while time.time() < deadline and subprocess.run(["pgrep", "-f", "iface='wt1_2-eth0'"],
                                                    capture_output=True).returncode != 0:
        time.sleep(0.05)  # started
    while time.time() < deadline and subprocess.run(["pgrep", "-f", "iface='wt1_2-eth0'"],
                                                    capture_output=True).returncode == 0:
        time.sleep(0.05)  # finished
    time.sleep(0.2)
    wait_t(5.5)
    proc.stdin.write("status\ntables wt1_1\npaths\n")
    proc.stdin.flush()
    wait_t(9.9)
    time.sleep(0.5)
    text, _ = proc.communicate("exit\n", timeout=60)
    assert proc.returncode == 0, text
    assert "link s1-s3 down" in text, text
    assert "wt1_1" in text and "1/1" in text, text  # tables: T2 1/1 and T3 1/1 again after the reroute
    assert "down links: s1-s3 (seen by the SDN app: s1-s3)" in text, text  # the run's own and the app's view
    s = json.loads((out / "summary.json").read_text())
    assert s["sdn_counters"].get("drop_no_flow:10.0.1.1->10.0.0.21", 0) >= 20, text  # the spoofed datagrams
    assert s["wire_rejected"]["sdc1"]["rejected"] == 0  # none reached the SDC
    (rec,) = s["recoveries"]
    assert rec["cause"] == "dr" and rec["fault"]["type"] == "link_down"
    assert rec["recovery_ms"] is not None and rec["recovery_ms"] < 100
    assert_no_leftovers()


def test_fast_failover_repairs_in_the_data_plane_before_dr(tmp_path):
    s = run_scenario(SC / "link_failure_ff.yaml", tmp_path)
    fault = next(e for e in s["events"] if e["type"] == "link_down" and e["source"] == "timeline")
    t_f = fault["t_effective"]
    # the turbine's longest control pause around the fault (every pause of two missing samples or more
    # is recorded; none means at most 2 Ts): below the 40 ms DR hold, so the switches repaired it
    (rec,) = [r for r in s["interruptions"] if r["wt"] == "wt1_1"]
    assert rec["recovered"] and rec["t_fault"] == pytest.approx(t_f)
    # (not restored_ms: on a loaded machine the fault's chain of short pauses can run on for 0.9 s,
    # and restored_ms is dated from the longest of them — seen at 7d474d2: 16 ms pause, "912 ms")
    assert (rec["interruption_ms"] or 0.0) < 40.0, rec
    assert ctrl_after(s, t_f + 0.1)
    assert not [e for e in s["events"] if e["type"] == "dr" and e["source"] == "sdn_app" and not e.get("after_end")]
    assert s["openflow"]["tx_OFPGroupMod"] >= 2
    assert ctrl_after(s, 3.9)


def test_duplicated_path_carries_on_through_a_link_failure_without_dr(tmp_path):
    """1+1 duplication (link_failure_prp.yaml): both ends receive every packet twice and drop the copy
    by its sequence number; when c1-c2 fails under wt3_1's first leg, the second leg carries on — no DR,
    the app pairs the path again as the network allows, and again when the link returns. At time scale 4:
    every link event pauses all of Open vSwitch's forwarding for 10-20 ms of wall time on this network
    (docs/sdn.md), which must stay well inside the DR hold."""
    s = run_scenario(SC / "link_failure_prp.yaml", tmp_path, "--time-scale", "4")
    visc = next(e for e in s["events"] if e["type"] == "visc_on" and e["source"] == "sdn_app")
    assert "c1" in visc["path"] and "c2" in visc["path"], "the failed link is on the first leg"
    fault = next(e for e in s["events"] if e["type"] == "link_down" and e["source"] == "timeline")
    repaired = [e for e in s["events"] if e["type"] == "pair_repaired"]
    assert [e["link"] for e in repaired] == [["c1", "c2"]] and "c1" not in repaired[0]["path"]
    assert [e["wt"] for e in s["events"] if e["type"] == "reprotected"] == ["wt3_1"]  # paired again at 3 s
    assert not [e for e in s["events"] if e["type"] == "dr" and e["source"] == "sdn_app" and not e.get("after_end")]
    (rec,) = [r for r in s["interruptions"] if r["wt"] == "wt3_1"]
    assert rec["recovered"] and rec["t_fault"] == pytest.approx(fault["t_effective"])
    # what pause is left is Open vSwitch's own handling of the port event (its one main thread
    # forwards every `system` port): below the DR hold, no repair waited for
    assert (rec["interruption_ms"] or 0.0) < 40.0, rec
    assert ctrl_after(s, 3.9, "wt3_1")
    plant = json.loads((tmp_path / "plant_stats.json").read_text())["turbines"]["wt3_1"]
    sdc = json.loads((tmp_path / "sdc1_stats.json").read_text())
    # duplicated from 1 s to 2 s and from 3 s to 4 s of the 3 s of ViSC: about two copies in three
    assert plant["ctrl_stale"] >= 0.4 * plant["ctrl_rx"], plant
    assert sdc["turbines"]["wt3_1"]["meas_stale"] >= 0.4 * plant["meas_tx"], sdc
    assert plant["rx_rejected"] == 0 and sdc["rx_wire"]["rejected"] == 0
    assert_no_leftovers()


def test_controller_redundancy_slave_takes_over_and_reroutes(tmp_path):
    s = run_scenario(SC / "controller_failover.yaml", tmp_path)
    assert s["processes_killed"] == ["controller"]
    takeover = [e for e in s["events"] if e["type"] == "controller_takeover"]
    assert len(takeover) == 1 and 2.0 < takeover[0]["t"] < 2.2
    assert s["controllers"]["instance2"]["role"] == "master"
    # traffic kept flowing through the takeover: no interruption around t = 2 s
    assert not [g for g in s["turbines"]["wt1_1"]["ctrl_gaps"] if 1.95 < g[0] < 2.3 and g[1] - g[0] > 0.02]
    (rec,) = s["recoveries"]
    assert rec["cause"] == "dr" and rec["recovery_ms"] is not None and rec["recovery_ms"] < 100
    dr = next(e for e in s["events"] if e["type"] == "dr" and not e.get("shadow"))
    assert dr["source"] == "sdn_app2"
