"""Issue 42 item 7: a turbine's counts after an SDC failover add up the same way everywhere — per SDC
in summary.json and on the CLI's line, and an SDC that left no statistics (killed) named, not
silently left out."""

from __future__ import annotations

from types import SimpleNamespace

from scenarios.cli import _by_sdc
from scenarios.summary import sdc_stats_missing


def test_a_killed_sdc_without_statistics_is_named():
    run = SimpleNamespace(processes=SimpleNamespace(procs={"sdc1.sdc": 0, "sdc2.sdc": 0, "plant": 0}),
                          killed={"sdc1.sdc"})
    assert sdc_stats_missing(run, {"sdc2": {}}) == {"sdc1": "killed"}
    assert sdc_stats_missing(run, {"sdc1": {}, "sdc2": {}}) == {}
    crashed = SimpleNamespace(processes=run.processes, killed=set())
    assert sdc_stats_missing(crashed, {"sdc1": {}}) == {"sdc2": "ended without writing them"}


def test_the_cli_line_shows_each_sdcs_share_when_more_than_one_counts():
    two = {"per_sdc": {"sdc1": {"meas_rx": 2900, "ctrl_tx": 2899}, "sdc2": {"meas_rx": 1442, "ctrl_tx": 1442}}}
    assert _by_sdc(two, {}) == " [sdc1 2900/2899, sdc2 1442/1442]"
    one_left = {"per_sdc": {"sdc2": {"meas_rx": 1442, "ctrl_tx": 1442}}}
    assert _by_sdc(one_left, {"sdc_stats_missing": {"sdc1": "killed"}}) == " [sdc1 n/a, sdc2 1442/1442]"
    assert _by_sdc(one_left, {}) == ""


def test_ak_conflicts_are_printed(capsys, tmp_path):
    from scenarios.cli import _print_result

    summary = {"scenario": "x", "steps": 10, "step_s": 0.00067, "late_steps": 0, "turbines": {}, "recoveries": [],
               "sdn_counters": {"ak_conflict": 2},
               "events": [{"type": "ak_conflict", "wt": "wt1_1", "t": 1.5}, {"type": "ak_conflict", "wt": "wt1_1", "t": 3.0}]}
    _print_result(summary, tmp_path)
    assert "2 AK conflict(s) for wt1_1" in capsys.readouterr().out
