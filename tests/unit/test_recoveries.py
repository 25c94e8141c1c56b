"""How summary.json's ``recoveries`` are derived from a fault, the turbine's control-packet gaps
and the SDN app's reaction (pure, no network)."""

from __future__ import annotations

import pytest

from scenarios.summary import on_run_clock, recoveries

T0 = 1000.0


def turbine(gaps, last):
    return {"ctrl_gaps_wall": [(T0 + a, T0 + b) for a, b in gaps], "last_ctrl_wall": T0 + last}


def test_restored_after_dr():
    fault = {"t": 2.0, "t_effective": 2.003, "type": "link_down", "a": "s1", "b": "s3", "source": "timeline"}
    stats = {"wt1_1": turbine([(1.5, 1.506), (2.0032, 2.054)], last=3.99)}
    events = [{"t": 2.049, "type": "dr", "wt": "wt1_1"}]
    (rec,) = recoveries([fault], stats, events, T0, duration_s=4.0)
    assert rec["cause"] == "dr" and rec["t_fault"] == pytest.approx(2.003)
    assert rec["recovery_ms"] == pytest.approx(51.0) and rec["detect_ms"] == pytest.approx(46.0)
    assert rec["t_loss"] == pytest.approx(2.0032)


def test_stopped_for_good_is_not_restored_even_with_a_packet_in_flight():
    fault = {"t": 2.0, "type": "kill", "host": "sdc1", "process": "sdc"}
    stats = {"wt1_1": turbine([(1.999, 2.006)], last=2.006)}
    (rec,) = recoveries([fault], stats, [], T0, duration_s=4.0)
    assert rec["recovery_ms"] is None and rec["t_restored"] is None and rec["cause"] == "none"


def test_jitter_and_unaffected_turbines_are_not_recoveries():
    fault = {"t": 2.0, "type": "link_down", "a": "s2", "b": "s3"}
    stats = {"wt1_1": turbine([(2.01, 2.016)], last=3.99), "wt1_2": turbine([], last=3.99)}
    assert recoveries([fault], stats, [], T0, duration_s=4.0) == []


def test_failover_reaction_names_turbines():
    fault = {"t": 2.0, "type": "kill", "host": "sdc1", "process": "sdc"}
    stats = {"wt1_1": turbine([(2.0005, 2.046)], last=3.99)}
    events = [{"t": 2.04, "type": "sdc_failover", "turbines": ["wt1_1"]}]
    (rec,) = recoveries([fault], stats, events, T0, duration_s=4.0)
    assert rec["cause"] == "sdc_failover" and rec["recovery_ms"] == pytest.approx(46.0)


def test_a_failure_while_no_sdn_app_runs_says_so():
    fault = {"t": 2.0, "type": "link_down", "a": "s1", "b": "s3"}
    stats = {"wt1_1": turbine([], last=2.001)}
    (rec,) = recoveries([fault], stats, [], T0, duration_s=4.0, no_controller=[[1.5, None]])
    assert rec["cause"] == "no_controller" and rec["t_restored"] is None
    (rec,) = recoveries([fault], stats, [], T0, duration_s=4.0, no_controller=[[0.5, 1.0]])
    assert rec["cause"] == "none"  # an SDN app was running again at the fault


def test_a_partition_healed_when_a_link_returns_is_a_recovery():
    fault = {"t": 2.0, "type": "link_down", "a": "s1", "b": "s3"}
    stats = {"wt1_1": turbine([(2.0005, 2.31)], last=3.99)}
    events = [{"t": 2.045, "type": "no_path", "wt": "wt1_1"}, {"t": 2.305, "type": "path_restored", "wt": "wt1_1"}]
    (rec,) = recoveries([fault], stats, events, T0, duration_s=4.0)
    assert rec["cause"] == "no_path" and rec["recovery_ms"] == pytest.approx(310.0)


def test_rejections_by_service_and_reason():
    from scenarios.summary import rejections

    out = rejections({"rx_rejected": {"future_seq": 2, "length": 1}}, {"sdc1": {"rejected": {"unknown_turbine": 5}}},
                     {"counters": {"drop_bad_value": 1, "drop_no_flow:10.0.0.1->10.0.0.2": 7, "heartbeats": 9},
                      "wire": {"ok": 100, "length": 3, "rejected": 3}}, {"rx_reject_unknown_req_id": 4})
    assert out["sdc1"] == {"unknown_turbine": 5} and out["sdn_app"] == {"bad_value": 1, "length": 3}
    assert out["owfcc"] == {"unknown_req_id": 4} and out["total"] == 2 + 1 + 5 + 1 + 3 + 4


def test_events_jsonl_has_the_sdn_apps_clock_readings_on_the_run_axis():
    # seen in a recovery run: events.jsonl's dr had t on the run's axis but t_loss/t_detect as clock readings
    # (summary.py and the live event tail both put events through on_run_clock)
    e = on_run_clock({"t_wall": T0 + 2.05, "type": "dr", "wt": "wt1_1", "t_loss": T0 + 2.001, "t_detect": T0 + 2.05,
                      "new_path": ["sdc1", "s1"]}, T0)
    assert e["t"] == pytest.approx(2.05) and e["t_loss"] == pytest.approx(2.001) and e["t_detect"] == pytest.approx(2.05)
    assert "t_wall" not in e and e["new_path"] == ["sdc1", "s1"]
    plant = on_run_clock({"t": 2.06, "type": "ctrl_restored", "t_loss": 2.01}, T0)  # already on the axis
    assert plant["t_loss"] == 2.01
