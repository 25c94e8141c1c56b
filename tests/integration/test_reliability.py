"""Reliability and security on real Mininet + Open vSwitch + os-ken: hostile datagrams at every
port, a partition reported once and healed, forged AKs, a crashed service restarted, a failure
while no SDN application runs. Assertions are about what the services do (counted, survived,
recovered), not about this machine's timing."""

from __future__ import annotations

import pytest
import yaml

from tests.integration.helpers import ROOT, TEST_TIME_SCALE, assert_no_leftovers, run_scenario

pytestmark = pytest.mark.network
SC = ROOT / "scenarios"


def missing_outside(summary: dict, wt: str, windows: list[tuple[float, float]], t_from: float) -> float:
    """Fraction of the control packets expected at ``wt`` from ``t_from`` to the end, outside
    ``windows``, that did not arrive (from the turbine's recorded gaps between control packets)."""
    step = summary["step_s"]
    inside = lambda t: any(a <= t <= b for a, b in windows)  # noqa: E731
    gaps = [(a, b) for a, b in summary["turbines"][wt]["ctrl_gaps"] if a >= t_from and not inside(a) and not inside(b)]
    expected = (summary["duration_s"] - t_from - sum(b - a for a, b in windows)) / step
    return sum((b - a) / step - 1 for a, b in gaps) / expected


def test_hostile_datagrams_at_every_port_are_counted_and_control_goes_on(tmp_path):
    # the heaviest network test (21,000 datagrams, a backup SDC): k = 4, so that a stall of the
    # busy machine (70 ms wall seen at k = 2, after the fuzz window) is not read as a lost path
    k = max(4.0, float(TEST_TIME_SCALE))
    s = run_scenario(SC / "fuzz_paper.yaml", tmp_path, "--time-scale", f"{k:g}", timeout=300 * k / float(TEST_TIME_SCALE))
    assert s["processes_exited_early"] == {} and s["restarts"] == {}, "a service died under fuzzing"
    sent = {k: v for k, v in s["fuzz"].items()}
    assert sum(v["total"] for v in sent.values()) >= 20_000
    to = {}
    for result in sent.values():
        for target, kinds in result["sent"].items():
            to[target] = to.get(target, 0) + sum(kinds.values())
    rejected = s["rejected"]
    # what reached a service was dropped and counted by reason (a few are lost in the switches'
    # queues, and a mutation that is still a valid, newer message is used, not rejected)
    assert sum(rejected["sdc1"].values()) >= 0.8 * to["10.0.0.21:50010"]
    plant_seen = sum(rejected["plant"].values()) + s["turbines"]["wt1_1"]["packets"]["ctrl_stale"]
    assert plant_seen >= 0.8 * to["10.0.1.1:50020"]
    to_app = to["10.0.0.254:50000"] * 2 + to[next(t for t in to if t.endswith(":50030"))]
    assert sum(rejected["sdn_app"].values()) >= 0.8 * to_app
    for service in ("plant", "sdc1", "sdn_app"):
        assert rejected[service].get("internal", 0) == 0, f"{service} hit an unexpected exception"
    # outside the fuzz window (2-6 s) the SDViSC keeps its control packets
    assert missing_outside(s, "wt1_1", [(2.0, 6.1)], t_from=0.7) <= 0.02
    assert s["turbines"]["wt1_1"]["last_ctrl_rx_t"] > 8.9
    assert not [e for e in s["events"] if e["type"] == "dr" and e["t"] > 6.1 and not e.get("after_end")]
    assert_no_leftovers()


def test_a_partition_is_reported_once_and_healed(tmp_path):
    s = run_scenario(SC / "partition_farm.yaml", tmp_path)
    kinds = [e["type"] for e in s["events"] if e.get("source") == "sdn_app"]
    assert "reroute_failed" not in kinds
    no_path = [e for e in s["events"] if e["type"] == "no_path"]
    story = [(e["t"], e.get("source"), e["type"], e.get("wt"), e.get("link"), e.get("t_loss")) for e in s["events"]
             if e["type"] in ("no_path", "path_restored", "dr", "link_up", "link_down", "path_ready", "restore_links")]
    assert sorted(e["wt"] for e in no_path) == ["wt2_1", "wt4_1"], f"one no_path per cut-off turbine: {story}"
    assert all(2.5 < e["t"] < 3.5 for e in no_path)
    restored = {e["wt"] for e in s["events"] if e["type"] == "path_restored"}
    assert restored == {"wt2_1", "wt4_1"}
    healed = [r for r in s["recoveries"] if r["fault"]["a"] == "sub1"]
    assert {r["wt"] for r in healed} == {"wt2_1", "wt4_1"}
    assert all(r["cause"] == "no_path" and r["t_restored"] is not None and r["t_restored"] > 3.5 for r in healed)
    assert s["tables"]["T3"]["wt2_1"] == "1/1" and s["tables"]["T3"]["wt4_1"] == "1/1"
    assert_no_leftovers()


@pytest.mark.parametrize("topology", ["farm", "paper"])
def test_forged_aks_from_another_host(tmp_path, topology):
    """AK = 0 for wt1_1 sent by wt1_2, first with its own addresses, then with the victim's IP and
    MAC. Own addresses: dropped everywhere. Impersonation: dropped where the turbine sits on an
    OpenFlow port (farm: ingress check); behind the paper topology's L2 switch the controller
    cannot tell (documented in docs/sdn.md)."""
    topo = ({"name": "farm", "clusters": 5, "turbines": 10, "layout": "compact"} if topology == "farm"
            else {"name": "paper", "clusters": 1, "turbines": 2})
    sc = {"name": f"spoof_{topology}", "topology": topo, "duration_s": 4.5, "plant": {"model": "minimal"},
          "sdc": {"backup": False},
          "timeline": [{"t": 0.5, "do": "visc_on", "wt": "wt1_1"},
                       {"t": 1.5, "do": "spoof_ak", "host": "wt1_2", "victim": "wt1_1", "count": 100, "duration_s": 1.0},
                       {"t": 3.0, "do": "spoof_ak", "host": "wt1_2", "victim": "wt1_1", "impersonate": True,
                        "count": 100, "duration_s": 1.0}]}
    path = tmp_path / "spoof.yaml"
    path.write_text(yaml.safe_dump(sc))
    s = run_scenario(path, tmp_path / "out")
    counters = s["sdn_counters"]
    assert counters.get("drop_ak_unregistered", 0) >= 95  # own addresses: never taken for wt1_1's
    dr_in_first = [e for e in s["events"] if e["type"] == "dr" and 1.5 <= e["t"] < 3.0]
    assert dr_in_first == []
    if topology == "farm":
        assert counters.get("drop_ak_wrong_port", 0) >= 95
        # a DR the app decided while the run was being stopped is no forged AK's (`after_end`; seen under
        # one-core load: a loss 8 ms before the end, the DR 35 ms after it)
        assert not [e for e in s["events"] if e["type"] == "dr" and not e.get("after_end")], "a forged AK caused a DR"
    assert_no_leftovers()


def test_a_forged_ak_stream_behind_the_l2_switch_changes_nothing_and_a_real_failure_is_still_dr(tmp_path):
    """Issue 42 item 1, with real spoofed frames: wt1_2 sends AK = 0 for wt1_1 with wt1_1's own IP
    and MAC through the paper topology's non-OpenFlow L2 switch (seq 10**6 + n, ctrl_rx 0, every
    2 ms). The app follows wt1_1's genuine AK stream: no DR decided on the forged one, every forged
    AK dropped, the conflict reported. A second forgery runs while s1-s3 really fails: that failure is
    still DR'd. (On an idle machine also no control gap over 5 ms during the forgeries: docs/sdn.md.)"""
    sc = {"name": "forged_ak_stream", "topology": {"name": "paper", "clusters": 1, "turbines": 2}, "duration_s": 5.0,
          "plant": {"model": "minimal"}, "sdc": {"backup": False},
          "sdn": {"dr_hold_s": 0.040, "dynamic_routing": True, "reroute_on_port_status": False},
          "timeline": [{"t": 0.5, "do": "visc_on", "wt": "wt1_1"},
                       {"t": 1.5, "do": "spoof_ak", "host": "wt1_2", "victim": "wt1_1", "impersonate": True,
                        "count": 200, "duration_s": 0.4, "seq0": 1_000_000, "ctrl_rx": 0},
                       {"t": 3.0, "do": "spoof_ak", "host": "wt1_2", "victim": "wt1_1", "impersonate": True,
                        "count": 500, "duration_s": 1.0, "seq0": 2_000_000, "ctrl_rx": 0},
                       {"t": 3.3, "do": "link_down", "a": "s1", "b": "s3"}]}
    path = tmp_path / "forged.yaml"
    path.write_text(yaml.safe_dump(sc))
    s = run_scenario(path, tmp_path / "out", "--time-scale", "4")
    assert sum(r["total"] for r in s["fuzz"].values()) == 700, s["fuzz"]
    conflicts = [e for e in s["events"] if e["type"] == "ak_conflict"]
    assert conflicts and all(e["wt"] == "wt1_1" for e in conflicts)
    assert any(1.5 <= e["t"] < 2.0 for e in conflicts) and any(3.0 <= e["t"] < 4.0 for e in conflicts)
    assert s["sdn_counters"].get("ak_conflict", 0) == len(conflicts)
    assert s["sdn_counters"].get("drop_ak_other_stream", 0) >= 500  # (a few forged frames may be lost)
    dr = [e for e in s["events"] if e["type"] == "dr" and not e.get("after_end")]
    # no DR decided on the forged stream (each DR names the AK stream it rests on), whatever the load
    assert all(e["ak_seq"] < 1_000_000 for e in dr), [(e["t"], e["ak_seq"]) for e in dr]
    assert s["tables"]["T3"]["wt1_1"] == "1/1"
    # the real failure during the second forgery: if wt1_1's path crossed s1-s3 then, a DR dated from it
    # onto a path without s1-s3. (Forged frames with wt1_1's MAC teach the L2 switch wt1_1's MAC on
    # wt1_2's port: on a busy machine that steals real control packets — real losses, DR'd on the genuine
    # stream, sometimes before the failure; docs/sdn.md. So the DRs' number is not asserted.)
    hops = lambda p: [sorted(h) for h in zip(p, p[1:])]  # noqa: E731
    before = [e for e in dr if e["t"] < 3.3]
    path_then = before[-1]["new_path"] if before else ["sdc1", "s1", "s3", "l2", "wt1_1"]
    if ["s1", "s3"] in hops(path_then):
        first = min((e for e in dr if e["t"] >= 3.3), key=lambda e: e["t"])
        assert 3.3 - 0.01 <= first["t_loss"] < 3.35 and ["s1", "s3"] not in hops(first["new_path"])
    assert dr and ["s1", "s3"] not in hops(max(dr, key=lambda e: e["t"])["new_path"])
    assert s["turbines"]["wt1_1"]["last_ctrl_rx_t"] > 4.9, "control after the reroute"
    assert_no_leftovers()


def test_a_crashed_sdc_is_restarted_and_serves_again(tmp_path):
    sc = yaml.safe_load((SC / "smoke.yaml").read_text())
    sc.update(name="crash_sdc", duration_s=8.0, timeline=[{"t": 0.5, "do": "visc_on", "wt": "wt1_1"},
                                                       {"t": 1.5, "do": "kill", "host": "sdc1", "process": "sdc",
                                                        "crash": True}])
    path = tmp_path / "crash.yaml"
    path.write_text(yaml.safe_dump(sc))
    s = run_scenario(path, tmp_path / "out")
    assert s["restarts"] == {"sdc1.sdc": 1}
    assert any(e["type"] == "service_restarted" and e["process"] == "sdc1.sdc" for e in s["events"])
    assert any(e["type"] == "sdc_restarted" for e in s["events"]), "the SDN app saw the SDC come back"
    assert s["turbines"]["wt1_1"]["last_ctrl_rx_t"] > 7.9, "control resumed after the restart"
    assert_no_leftovers()


def test_a_failure_while_no_sdn_app_runs_is_reported_as_such(tmp_path):
    sc = yaml.safe_load((SC / "link_failure_dr.yaml").read_text())
    sc["name"] = "no_controller"
    sc["timeline"] = [{"t": 1.0, "do": "visc_on", "wt": "wt1_1"},
                      {"t": 1.5, "do": "kill", "host": "owfcc", "process": "controller"},
                      {"t": 2.0, "do": "link_down", "a": "s1", "b": "s3"}]
    path = tmp_path / "noctl.yaml"
    path.write_text(yaml.safe_dump(sc))
    s = run_scenario(path, tmp_path / "out")
    (rec,) = s["recoveries"]
    assert rec["cause"] == "no_controller" and rec["t_restored"] is None
    assert s["no_controller"] and 1.5 <= s["no_controller"][0][0] < 2.0
    assert_no_leftovers()
