"""The report's F…net items read their cases from scenarios/paper/ and agree with the offline
experiments they are compared with; F7net's changed scenario is a valid scenario (no network)."""

from __future__ import annotations

import numpy as np

from report import network_runs
from report.exp_grid import GRID_INERTIA
from report.exp_grid_net import _scr_timeline
from report.exp_parallel import M_Q
from scenarios.loader import load_scenario
from sdvisc.config import GRID_SCENARIO_KEYS


def test_f7net_variant_changes_only_the_scr_and_the_duration_and_still_loads(tmp_path):
    path = network_runs.write_variant(tmp_path, "f7_weak_grid_visc", "f7_weak_grid_visc_scr1.454",
                                      {"timeline": _scr_timeline(1.454), "duration_s": 3.0})
    original = load_scenario(network_runs.scenario_path("f7_weak_grid_visc"))
    sc = load_scenario(path)
    assert sc.name == "f7_weak_grid_visc_scr1.454" and sc.duration_s == 3.0
    scr = [e for e in sc.timeline if e.do == "scr"]
    assert len(scr) == 1 and scr[0].value == 1.454
    same = [e for e in sc.timeline if e.do != "scr"]
    assert same == [e for e in original.timeline if e.do != "scr"]
    assert sc.plant == original.plant and sc.topology == original.topology and sc.time_scale == "auto"


def test_the_network_cases_are_the_offline_ones():
    f4 = network_runs.load("f4_inertia_50mw")
    assert {GRID_SCENARIO_KEYS[k]: v for k, v in f4["plant"]["grid"].items()} == GRID_INERTIA
    f8 = [e for e in network_runs.timeline("f8_parallel_droop") if e["do"] == "visc_on"]
    assert np.allclose([e["params"]["m_q"] for e in f8], M_Q)
    f2 = network_runs.load("f2_trapezoid_025ms")
    assert f2["step_s"] == 0.00025 and f2["sdc"]["method"] == "trapezoid_cumulative" and f2["sdc"]["dtype"] == "float32"
    f7 = [e for e in network_runs.timeline("f7_weak_grid_visc") if e["do"] == "scr"]
    assert [e["t"] for e in f7] == [1.0]  # report/exp_weak.py's T_EVENT


def test_f9net_variants_keep_the_first_n_sdviscs_as_the_offline_search_does(tmp_path):
    from plant.cases import FIRST_VISC
    from report.exp_cyber import first_visc

    path = network_runs.write_variant(tmp_path, "f9_scr151_4visc", "f9_scr151_3visc", {"timeline": first_visc(3)})
    sc = load_scenario(path)
    assert [e.wt for e in sc.timeline if e.do == "visc_on"] == ["wt3_1", "wt3_2", "wt3_3"]
    assert [e.value for e in sc.timeline if e.do == "scr"] == [1.51]
    assert FIRST_VISC == 20  # wt3_1: turbine 20 of the farm (clusters of ten, 0-based)


def test_f8net_variant_sets_the_grid_emf_the_plant_reads(tmp_path):
    path = network_runs.write_variant(tmp_path, "f8_parallel_droop", "f8_parallel_droop_from_097", {
        "plant": lambda plant: {**plant, "grid": {**(plant.get("grid") or {}), "e": 0.97952},
                                "p_star": {"wt3_1": 0.0}}})
    sc = load_scenario(path)
    assert sc.plant.grid.given() == {"e_grid": 0.97952} and sc.plant.p_star == {"wt3_1": 0.0}


def test_quick_without_only_runs_two_network_experiments_and_says_why_not_the_others(tmp_path):
    import pytest

    from report.__main__ import quick_network_subset
    from report.catalogue import EXPERIMENTS, QUICK_NETWORK
    from report.registry import Context, NotRun

    by_id = {e.id: e for e in EXPERIMENTS}
    assert all(by_id[i].kind == "cyber" for i in QUICK_NETWORK)
    for exp in EXPERIMENTS:
        kept = quick_network_subset(exp)
        if exp.kind == "offline" or exp.id in QUICK_NETWORK:
            assert kept is exp
        else:
            with pytest.raises(NotRun, match=f"--only {exp.id}"):
                kept.run(Context(out_dir=tmp_path, quick=True))


def test_runs_of_the_same_shape_share_a_calibration_start_and_others_do_not():
    shapes = {n: network_runs.shape_of(network_runs.load(n)) for n in
              ("f3_voltage_step", "f4_inertia_50mw", "f8_parallel_droop", "f1_tustin_vs_hd", "f2_trapezoid_025ms",
               "f3_voltage_step_cluster3")}
    assert shapes["f3_voltage_step"] == shapes["f4_inertia_50mw"]  # the onshore unit wt6_1, 0.67 ms
    assert shapes["f3_voltage_step_cluster3"] == shapes["f8_parallel_droop"]  # cluster 3, 0.67 ms
    assert shapes["f3_voltage_step"] != shapes["f8_parallel_droop"]  # another topology (wt6_1 on sub1)
    assert shapes["f1_tustin_vs_hd"] != shapes["f3_voltage_step"]  # one ViSC per cluster: other paths
    assert shapes["f2_trapezoid_025ms"] != shapes["f1_tustin_vs_hd"]  # same turbines, Ts 0.25 ms


def test_a_new_shape_starts_its_search_where_a_run_of_the_same_topology_and_period_held(monkeypatch):
    monkeypatch.setattr(network_runs, "_chosen_k", {})
    monkeypatch.setattr(network_runs, "_chosen_k_near", {})
    f1, f3, f4, f2 = (network_runs.load(n) for n in ("f1_tustin_vs_hd", "f3_voltage_step_cluster3",
                                                     "f4_inertia_50mw_cluster3", "f2_trapezoid_025ms"))
    assert network_runs.calibration_start(f1) is None  # nothing known: from k = 1
    network_runs.remember_calibration(f1, 16.0)
    assert network_runs.calibration_start(f3) == 16.0  # other turbines, same farm and period
    assert network_runs.calibration_start(f2) is None  # Ts 0.25 ms: nothing known
    network_runs.remember_calibration(f3, 32.0)
    assert network_runs.calibration_start(f4) == 32.0 and network_runs.calibration_start(f1) == 16.0  # own shape first
    assert network_runs.calibration_start({**f4, "time_scale": 8}) is None  # a fixed k is not calibrated


def test_b1net_delays_a_link_on_every_cluster3_path_and_fixes_the_time_scale(tmp_path):
    import networkx as nx

    from report.exp_delay_net import CLUSTER3, IMPAIRED_LINK, variant
    from topologies import topos

    sc = load_scenario(network_runs.write_variant(tmp_path, "f1_tustin_vs_hd", "b1net_delay_1ms", variant(1.0, 16.0)))
    assert sc.time_scale == 16.0 and [e.wt for e in sc.timeline if e.do == "visc_on"] == CLUSTER3
    assert [(link.a, link.b, link.delay_ms) for link in sc.links] == [(*IMPAIRED_LINK, 0.5)]  # d/2 each way
    assert sc.plant.record == CLUSTER3
    no_delay = load_scenario(network_runs.write_variant(tmp_path, "f1_tustin_vs_hd", "b1net_0", variant(0.0, 16.0)))
    assert not no_delay.links
    topo = topos[sc.topology.name](**sc.topology.params())
    graph = nx.Graph(topo.links())
    for wt in CLUSTER3:
        path = nx.shortest_path(graph, "sdc1", wt)
        assert any({a, b} == set(IMPAIRED_LINK) for a, b in zip(path, path[1:])), path


def test_b1net_adds_up_the_round_trip_histograms_of_the_four():
    from report.exp_delay_net import _merged, _share

    hist = _merged({"wt3_1": {"1": 120, "2": 2557}, "wt3_2": {"2": 100, "3": 3}})
    assert hist == {"1": 120, "2": 2657, "3": 3}
    assert _share(hist) == "1: 4.3%, 2: 95.6%, 3: 0.1%"
    # the runner's last bin (more than 7 samples) comes last, whatever the order the turbines gave
    wide = _merged({"wt3_1": {">7": 900, "7": 100}, "wt3_2": {">7": 5, "2": 1000}})
    assert wide == {"2": 1000, "7": 100, ">7": 905} and list(wide) == ["2", "7", ">7"]


def test_a_calibrated_run_that_did_not_hold_is_run_again_and_a_fixed_one_never():
    from scenarios.summary import time_advice
    late = time_advice(16, 3000, 0, {"wt1_1": 0.999, "wt3_4": 0.985})  # 1.5 % of wt3_4's answers late
    held = time_advice(16, 3000, 20, {"wt1_1": 0.999, "wt3_4": 0.995})  # 0.7 % of steps, 0.5 % of answers
    assert late and "wt3_4" in late and "--time-scale 32" in late and held is None
    calibrated = {"time": {"time_scale": 16, "calibration": {"time_scale": 16, "trials": []}}}
    fixed = {"time": {"time_scale": 16, "calibration": None}}
    assert network_runs.did_not_hold({**calibrated, "advice": late}) == late
    assert network_runs.did_not_hold({**calibrated, "advice": held}) is None
    assert network_runs.did_not_hold({**fixed, "advice": late}) is None  # B1net: late on purpose
    # a trip beside late answers may be the testbed's: run again; one with every answer in time is the physics'
    turbines = {"wt1_1": {"round_trip_samples": {"within_one": 0.9951}},
                "wt2_1": {"round_trip_samples": {"within_one": 1.0}}}
    tripped_late = {**calibrated, "advice": None, "turbines": turbines, "converter_trips": {"wt1_1": 1}}
    why = network_runs.did_not_hold(tripped_late)
    assert why and "wt1_1" in why and "--time-scale 32" in why
    assert network_runs.did_not_hold({**tripped_late, "converter_trips": {"wt2_1": 1}}) is None
    assert network_runs.did_not_hold({**tripped_late, "converter_trips": {"wt1_1": 0}}) is None
    assert network_runs.did_not_hold({**fixed, "turbines": turbines, "converter_trips": {"wt1_1": 1}}) is None


def test_the_page_says_which_calibrated_k_a_run_did_not_hold_at():
    from report.page import _time_scale_text

    again = {"c2_link_failure_no_dr": {"time_scale": 1.0, "advice": "…", "first_attempt": "/x"}}
    text = _time_scale_text({"c2_link_failure_no_dr": 2.0, "c2_link_failure_dr": 2.0}, again)
    assert text == "k = 2 (c2_link_failure_no_dr; at k = 1 it did not hold); k = 2 (c2_link_failure_dr)"
    assert _time_scale_text("offline (no clock)") == "offline (no clock)"


def test_the_report_knows_the_calibrations_largest_candidate():
    from scenarios.calibrate import CANDIDATES

    assert network_runs.LARGEST_CANDIDATE == max(CANDIDATES)


def test_the_network_arrangement_picks_files_offline_twins_and_the_f7_case():
    import pytest

    from plant.cases import COMPARISON_UNIT
    from report import net_arrangement as na
    from report.exp_weak import NET_CASE, SDVISC, net_case

    assert na.CHOSEN == na.ONSHORE and na.scenario("f3_voltage_step") == "f3_voltage_step"
    assert list(na.indices()) == [COMPARISON_UNIT] and net_case() == SDVISC[False]  # F7's own SDViSC
    assert na.offline_plant(activate=False).n == 51 and "wt6_1" in na.label()
    try:
        na.choose(na.CLUSTER3)
        assert na.scenario("f7_weak_grid_visc") == "f7_weak_grid_visc_cluster3"
        assert list(na.indices()) == [20, 21, 22, 23] and net_case() == NET_CASE
        assert na.offline_plant(activate=False).n == 50
    finally:
        na.choose(na.ONSHORE)
    with pytest.raises(ValueError, match="unknown arrangement"):
        na.choose("offshore")
    assert all(network_runs.scenario_path(f"{n}_cluster3").exists() for n in (
        "f3_voltage_step", "f4_inertia_50mw", "f5_inertia_100mw_battery", "f6_slg_fault_current", "f7_weak_grid_visc"))
