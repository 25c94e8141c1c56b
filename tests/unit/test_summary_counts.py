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


# ------------------------------------------------------------------ the summary builder (build_summary)

def _run(tmp_path, scenario, files: dict, killed=("sdc1.sdc",)):
    import json as _json

    from sdvisc.clock import Clock

    for name, content in files.items():
        (tmp_path / name).write_text(_json.dumps(content))
    return SimpleNamespace(out=tmp_path, scenario=scenario, timeline_events=[], t0=100.0, clock=Clock(1.0, 0.0),
                           desc={}, datapath="user", exited_early={}, killed=set(killed), restarts={},
                           no_controller=[], processes=SimpleNamespace(procs={"sdc1.sdc": 0, "sdc2.sdc": 0}))


def _sdc(final: bool, meas: int, ctrl: int, **extra) -> dict:
    return {"final": final, "t_written": 103.0, "turbines": {"wt1_1": {"meas_rx": meas, "ctrl_tx": ctrl, **extra}}}


def test_after_a_failover_the_turbine_counts_add_up_over_both_sdcs(tmp_path):
    """external_peer: sdc1 served until it was killed at 3 s (its snapshot), sdc2 after; the card
    counted every CTRL. meas_rx_sdc and ctrl_tx_sdc are the sums of per_sdc, and match the card's."""
    from scenarios.cli import _print_result
    from scenarios.loader import load_scenario
    from scenarios.summary import build_summary
    from tests.integration.helpers import ROOT

    sc = load_scenario(ROOT / "scenarios" / "external_peer.yaml")
    card = {"turbines": {"wt1_1": {"meas_tx": 4400, "ctrl_rx": 4348, "ak_tx": 300}}, "steps": 4400}
    run = _run(tmp_path, sc, {"gtnet_card_stats.json": card, "sdc1_stats.json": _sdc(False, 2906, 2906),
                              "sdc2_stats.json": _sdc(True, 1442, 1442, meas_inactive=2900)})
    s = build_summary(run, completed=True)
    row = s["turbines"]["wt1_1"]
    assert row["packets"]["meas_rx_sdc"] == sum(r["meas_rx"] for r in row["per_sdc"].values()) == 4348
    assert row["packets"]["ctrl_tx_sdc"] == sum(r["ctrl_tx"] for r in row["per_sdc"].values()) == row["packets"]["ctrl_rx"]
    assert s["sdc_stats_partial"] == {"sdc1": {"as_of_t": 3.0, "why": "killed"}} and s["sdc_stats_missing"] == {}
    s["step_s"] = sc.step_s
    _print_result(s, tmp_path)


def test_a_real_card_without_a_capture_shows_na_not_zero(tmp_path, capsys):
    from scenarios.cli import _print_result
    from scenarios.loader import load_scenario
    from scenarios.summary import build_summary
    from tests.integration.helpers import ROOT

    text = (ROOT / "scenarios" / "external_peer.yaml").read_text()
    text = text.replace("time_scale: 4", "time_scale: 1").replace("framing: native", "framing: native\n    emulate: false\n"
                                                                   "    interface: eth9")
    text = text.split("    misbehave:")[0] + "sdc:" + text.split("\nsdc:")[1]
    path = tmp_path / "real.yaml"
    path.write_text(text)
    sc = load_scenario(path)
    run = _run(tmp_path, sc, {"sdc1_stats.json": _sdc(False, 2906, 2906), "sdc2_stats.json": _sdc(True, 1442, 1442)})
    s = build_summary(run, completed=True)
    p = s["turbines"]["wt1_1"]["packets"]
    assert p["meas_tx"] is None and p["ctrl_rx"] is None and p["meas_rx_sdc"] == 4348
    assert s["steps"] is None and s["peer"]["emulated"] is False and "nothing" in s["peer"]["counted_at"]
    _print_result(s, tmp_path)
    out = capsys.readouterr().out
    assert "meas_tx=n/a" in out and "ctrl_rx=n/a" in out and "None" not in out and "0 steps" not in out
