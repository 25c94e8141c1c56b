"""The paper report's logic: verdicts from numbers, the boundary searches against closed forms, the
registry and its options, and a failed experiment kept apart from the others (no simulation)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from report import figures
from report.__main__ import main as report_main
from report.boundary import smallest_sufficient, threshold
from report.catalogue import EXPERIMENTS
from report.registry import Context, Experiment, Finding, NotRun, PaperClaim, select
from report.run import run_report
from report.verdicts import change_close_to, close_to, holds, ordered, relative_error


# ------------------------------------------------------------------------------------------ verdicts
def test_close_to_uses_the_stated_relative_tolerances():
    assert close_to(1.05, 1.0) == "yes"  # 5 % off
    assert close_to(1.2, 1.0) == "partly"  # 20 % off
    assert close_to(2.0, 1.0) == "no"
    assert close_to(-0.30, -0.33) == "yes"  # negative values: relative to |paper|
    assert close_to(float("nan"), 1.0) == "no" and relative_error(float("inf"), 1.0) == math.inf


def test_a_step_of_the_wrong_sign_is_never_reproduced():
    assert change_close_to(0.97, 1.02, 0.97, 1.02) == "yes"
    assert change_close_to(0.97, 1.01, 0.97, 1.02) == "partly"  # +0.04 of +0.05
    assert change_close_to(0.97, 0.975, 0.97, 1.02) == "no"
    assert change_close_to(0.97, 0.96, 0.97, 1.02) == "no"


def test_holds_and_ordered():
    assert holds(True) == "yes" and holds(False) == "no" and holds(False, partly=True) == "partly"
    assert ordered([0.1, 0.2, 0.3]) and not ordered([0.1, 0.1], strict=True) and ordered([0.1, 0.1], strict=False)
    assert ordered([3, 2, 1], increasing=False) and not ordered([3, 4], increasing=False)


def test_a_finding_needs_a_known_verdict_and_a_reason_unless_reproduced():
    Finding("1.0", "yes")
    with pytest.raises(ValueError, match="verdict"):
        Finding("1.0", "maybe", "because")
    with pytest.raises(ValueError, match="reason"):
        Finding("1.0", "no")


# ----------------------------------------------------------------------------------------- boundaries
def test_threshold_finds_a_closed_form_boundary_and_keeps_its_evidence():
    b = threshold(lambda x: x * x >= 2.0, 1.0, 2.0, xtol=1e-6)
    assert b.value == pytest.approx(math.sqrt(2.0), abs=1e-6)
    assert b.bracket[0] <= math.sqrt(2.0) <= b.bracket[1] and b.bracket[1] - b.bracket[0] <= 2e-6
    assert all((x * x >= 2.0) == ok for x, ok in b.evaluations)
    assert len(b.evaluations) < 30  # bisection, not a sweep


def test_threshold_works_either_way_round_and_says_when_nothing_changes():
    b = threshold(lambda scr: scr > 1.58, 1.0, 4.0, xtol=0.01)  # "holds above the boundary", as an SCR search
    assert b.value == pytest.approx(1.58, abs=0.01)
    none = threshold(lambda x: True, 1.0, 4.0, xtol=0.01)
    assert none.value is None and none.bracket is None and "no change" in none.note and len(none.evaluations) == 2


def test_smallest_sufficient_is_a_binary_search():
    calls = []

    def enough(n):
        calls.append(n)
        return n * n >= 50

    b = smallest_sufficient(enough, 0, 20)
    assert b.value == 8 and b.bracket == (7.0, 8.0)
    assert len(calls) <= math.ceil(math.log2(21)) + 1
    missing = smallest_sufficient(lambda n: n > 100, 0, 16)
    assert missing.value is None and "16" in missing.note


# ---------------------------------------------------------------------------- registry and options
def _exp(id_, run, claims=None):
    claims = claims if claims is not None else (PaperClaim(f"{id_}.a", f"claim of {id_}", "1.0"),)
    return Experiment(id_, f"title {id_}", "Fig. x", "offline", claims, run, "")


def test_select_is_case_insensitive_keeps_registry_order_and_names_unknown_ones():
    exps = [_exp(i, lambda ctx: {}) for i in ("F1", "F4", "C2")]
    assert [e.id for e in select(exps, "c2, f4")] == ["F4", "C2"]
    assert select(exps, None) == exps
    with pytest.raises(ValueError, match="X9.*known: F1, F4, C2"):
        select(exps, "F1,X9")


def test_every_claim_belongs_to_its_experiment_and_ids_are_unique():
    with pytest.raises(ValueError, match="does not belong"):
        _exp("F1", lambda ctx: {}, (PaperClaim("F2.a", "x", "1"),))
    ids = [c.id for e in EXPERIMENTS for c in e.claims]
    assert len(ids) == len(set(ids))
    assert {e.id for e in EXPERIMENTS} >= {f"F{i}" for i in range(1, 10)} | {"C1", "C2", "C3"}
    assert all(c.paper.strip() and c.text.strip() for e in EXPERIMENTS for c in e.claims)


def test_cli_rejects_an_unknown_experiment_and_lists(capsys):
    assert report_main(["--only", "X9"]) == 2
    assert "unknown experiment" in capsys.readouterr().err
    assert report_main(["--list", "--only", "F7"]) == 0
    out = capsys.readouterr().out
    assert "F7.a" in out and "F1.a" not in out


# ------------------------------------------------------------------------ isolation and the outputs
def _ok(ctx: Context):
    fig, axes = figures.new(1)
    axes[0, 0].plot(np.arange(3), np.arange(3))
    axes[0, 0].set_xlabel("t [s]")
    figures.save(ctx, fig, "ok_figure", "the paper's caption")
    return {"OK.a": Finding("0.97 p.u.", "partly", "because of the evidence")}


def _boom(ctx: Context):
    raise ZeroDivisionError("the experiment broke")


def _not_here(ctx: Context):
    raise NotRun("needs root")


def test_the_page_is_written_after_each_experiment(tmp_path):
    seen = []

    def look(ctx: Context):
        seen.append((json.loads((tmp_path / "claims.json").read_text()), (tmp_path / "index.html").read_text()))
        return {"LOOK.a": Finding("1", "yes")}

    run_report([_exp("OK", _ok, (PaperClaim("OK.a", "a", "1"),)), _exp("LOOK", look)], tmp_path, quick=False, argv=[],
               progress=lambda line: None)
    partial, partial_html = seen[0]
    assert not partial["complete"] and partial["pending"] == ["LOOK"] and [e["id"] for e in partial["experiments"]] == ["OK"]
    assert "Partial: still to run: LOOK" in partial_html
    final = json.loads((tmp_path / "claims.json").read_text())
    assert final["complete"] and [r["verdict"] for r in final["claims"]] == ["partly", "yes"]


def test_a_failed_experiment_is_reported_and_the_others_still_run(tmp_path):
    exps = [_exp("BOOM", _boom), _exp("OK", _ok, (PaperClaim("OK.a", "a", "1.02"), PaperClaim("OK.b", "b", "2"))),
            _exp("NR", _not_here)]
    lines = []
    data = run_report(exps, tmp_path, quick=True, argv=["--quick"], progress=lines.append)
    status = {e["id"]: e["status"] for e in data["experiments"]}
    assert status == {"BOOM": "failed", "OK": "ok", "NR": "not run"}
    rows = {r["id"]: r for r in data["claims"]}
    assert rows["BOOM.a"]["verdict"] == "failed" and "ZeroDivisionError: the experiment broke" in rows["BOOM.a"]["reason"]
    assert rows["OK.a"]["verdict"] == "partly" and rows["OK.a"]["testbed"] == "0.97 p.u." and rows["OK.a"]["paper"] == "1.02"
    assert rows["OK.b"]["verdict"] == "failed" and "no finding" in rows["OK.b"]["reason"]
    assert rows["NR.a"]["verdict"] == "not run" and rows["NR.a"]["reason"] == "needs root"
    assert all("--only" in r["command"] and "--quick" in r["command"] for r in rows.values())
    assert data["summary"] == {"yes": 0, "partly": 1, "consistent": 0, "no": 0, "failed": 2, "not run": 1}
    assert len(lines) == 6 and "BOOM failed" in lines[1] and "OK ok" in lines[3]
    on_disk = json.loads((tmp_path / "claims.json").read_text())
    assert on_disk["claims"] == json.loads(json.dumps(data["claims"]))
    html = (tmp_path / "index.html").read_text()
    assert "ZeroDivisionError" in html and "data:image/png;base64," in html and "the paper&#x27;s caption" in html
    assert "src='http" not in html and "<script" not in html  # one self-contained page
    assert data["complete"] and data["pending"] == [] and "Partial" not in html
    assert (tmp_path / "ok_figure.png").stat().st_size > 1000 and (tmp_path / "ok_figure.svg").stat().st_size > 1000


def test_the_paper_scenarios_load_and_run_the_full_farm_at_the_auto_time_scale():
    from report.network_runs import PAPER_SCENARIOS
    from scenarios.loader import load_scenario

    files = sorted(PAPER_SCENARIOS.glob("*.yaml"))
    assert len(files) >= 10
    for path in files:
        sc = load_scenario(path)
        assert sc.name == path.stem and sc.time_scale == "auto" and sc.plant.model == "full", path
    named = {w.split()[-1] for e in EXPERIMENTS if e.kind == "cyber" for w in e.command.split(";")}
    assert named and all((PAPER_SCENARIOS.parent.parent / n).exists() for n in named), named


# ------------------------------------------------------- beyond the paper (B1 delay, B2 sampling period)
def test_crossing_finds_where_a_made_up_error_curve_leaves_the_bound():
    from report.beyond import ACCEPT_PCT, crossing

    delays = [0, 0.5, 1, 2, 5, 10, 20]
    err = [0.3, 1.8, 4.9, 5.2, 30.0, 80.0, 90.0]  # leaves 5 % between 1 and 2 ms
    c = crossing(delays, [e > ACCEPT_PCT for e in err])
    assert (c.last_good, c.first_bad, c.recovers) == (1.0, 2.0, False)
    assert c.describe("within 5 %", "not", "ms") == "within 5 % up to 1 ms, not from 2 ms"
    never_leaves = crossing(delays, [False] * 7)
    assert never_leaves.first_bad is None and never_leaves.last_good == 20.0
    assert never_leaves.describe("stable", "unstable", "ms") == "stable over the whole sweep (0 ms to 20 ms)"
    never_within = crossing(delays, [True] * 7)
    assert never_within.first_bad == 0.0 and never_within.last_good is None
    assert never_within.describe("within 5 %", "not", "ms") == "never within 5 % (0 ms to 20 ms)"
    only_first = crossing(delays, [False] + [True] * 6)
    assert only_first.describe("stable", "unstable", "ms") == "stable only at 0 ms, unstable from 0.5 ms"
    # unsorted input, a bound left and re-entered (not monotonic: said so)
    c = crossing([5, 0.25, 2, 1], [True, False, False, True])
    assert (c.last_good, c.first_bad, c.recovers, c.swept) == (0.25, 1.0, True, (0.25, 1.0, 2.0, 5.0))
    assert "holds again" in c.describe("acceptable", "not", "ms")
    with pytest.raises(ValueError):
        crossing([0, 1], [True])


def test_the_unstable_criterion_trip_divergence_and_sustained_oscillation():
    from report.beyond import OSC_PTP_PU, OSC_WINDOW_S, instability, worst_pct

    t = np.arange(1, 3001) * 1e-3  # 3 s
    hd = 1.0 + 0.001 * np.sin(2 * np.pi * 5 * t)
    assert instability(t, hd.copy(), hd) is None
    assert instability(t, hd, hd, trips=[0, 1, 0, 0], trip_t=0.182) == "converter trip at 0.182 s"
    nan = hd.copy()
    nan[2000:] = np.nan
    assert instability(t, nan, hd).startswith("non-finite values from 2.001 s")
    osc = hd + np.where(t > t[-1] - OSC_WINDOW_S, 0.6 * OSC_PTP_PU * np.sin(2 * np.pi * 20 * t), 0.0)
    assert "oscillates" in instability(t, osc, hd)  # p-p 1.2 x the threshold above the HD's
    decayed = hd + np.where(t < 2.0, 0.2 * np.sin(2 * np.pi * 20 * t), 0.0)  # large, but over before the window
    assert instability(t, decayed, hd) is None
    assert worst_pct({"v": {"rms_over_range_pct": 0.5}, "q": {"rms_over_range_pct": 3.0}}) == 3.0
    assert worst_pct({"v": {"rms_over_range_pct": 0.5}, "q": {"rms_over_range_pct": math.inf}}) == math.inf


def _point(d, worst, own=0.0, unstable=None):
    return {"delay_ms": d, "worst_pct": worst, "own_worst_pct": own, "unstable": unstable}


def test_delay_limits_and_the_low_delay_verdict_on_made_up_sweeps():
    from report.exp_delay import LOW_DELAY_MS, limits, verdict_low_delay

    v_ref = [_point(0, 0.3), _point(0.5, 1.9, 1.7), _point(1, 100.0, 99.0, "converter trip at 0.182 s"),
             _point(20, 84.0, 84.0, "converter trip at 0.123 s")]
    lim = limits(v_ref)
    assert (lim["hd"].last_good, lim["hd"].first_bad) == (0.5, 1.0)
    assert lim["unstable"].first_bad == 1.0 and lim["own"].first_bad == 1.0
    assert verdict_low_delay(lim["hd"])[0] == "yes"
    # an unstable run is never "within", whatever its error
    lim = limits([_point(0, 0.3), _point(2, 1.0, 1.0, "|V_pcc| oscillates")])
    assert lim["hd"].first_bad == 2.0
    # leaves only past the low-delay bound: partly; never: no; not within even without delay: no
    late = limits([_point(0, 0.3), _point(LOW_DELAY_MS, 4.0), _point(20, 9.0)])["hd"]
    assert verdict_low_delay(late)[0] == "partly"
    never = limits([_point(0, 0.3), _point(20, 4.0)])["hd"]
    verdict, reason = verdict_low_delay(never)
    assert verdict == "no" and "whole sweep" in reason
    i_ref = limits([_point(0, 13.3, 0.0), _point(10, 13.4, 3.0), _point(20, 14.0, 8.0)])
    assert i_ref["hd"].last_good is None and (i_ref["own"].last_good, i_ref["own"].first_bad) == (10.0, 20.0)
    verdict, reason = verdict_low_delay(i_ref["hd"])
    assert verdict == "no" and "even without added delay" in reason


def test_acceptable_sampling_period_per_method_and_the_smaller_ts_verdict():
    from report.exp_sampling import CONVENTIONAL, acceptable_limits, case_for, fault_phase_ms
    from report.exp_sampling import verdict_needs_smaller_ts as verdict_needs_smaller_ts

    def pts(errors, unstable_from=None):
        return [{"ts_ms": ts, "worst_pct": e, "unstable": "trip" if unstable_from and ts >= unstable_from else None}
                for ts, e in zip((0.25, 0.67, 2.0, 5.0), errors)]

    table = {"Tustin": pts([0.2, 0.6, 1.2, 98.0], 5.0), CONVENTIONAL[0]: pts([0.2, 0.6, 1.2, 98.0], 5.0),
             CONVENTIONAL[1]: pts([0.2, 0.6, 1.2, 98.0], 5.0), CONVENTIONAL[2]: pts([0.3, 0.9, 4.0, 110.0], 2.0)}
    lims = acceptable_limits(table)
    assert lims["Tustin"].last_good == 2.0 and lims["Tustin"].first_bad == 5.0
    assert lims[CONVENTIONAL[2]].last_good == 0.67  # 4 % but tripped at 2 ms: not acceptable
    verdict, reason = verdict_needs_smaller_ts(lims)
    assert verdict == "partly" and "forward Euler" in reason
    table[CONVENTIONAL[0]] = table[CONVENTIONAL[1]] = pts([0.2, 7.0, 9.0, 98.0])
    assert verdict_needs_smaller_ts(acceptable_limits(table))[0] == "yes"
    table["Tustin"] = pts([6.0, 7.0, 9.0, 98.0])
    assert verdict_needs_smaller_ts(acceptable_limits(table))[0] == "no"
    every = {k: pts([0.1, 0.2, 0.3, 0.4]) for k in table}  # all acceptable everywhere: Tustin above none
    assert verdict_needs_smaller_ts(acceptable_limits(every))[0] == "no"
    # the plant step under each Ts, and where the 1.0 s fault falls between samples
    c = case_for(0.67, 2.0)
    assert c.plant_steps_per_sample == 3 and c.plant_step_s == pytest.approx(0.67e-3 / 3)
    assert case_for(0.25, 2.0).plant_steps_per_sample == 1 and case_for(5.0, 2.0).plant_steps_per_sample == 20
    assert fault_phase_ms(case_for(1.0, 2.0)) == 0.0 and 0 < fault_phase_ms(c) < 0.67


def test_a_measured_finding_only_for_a_question_beyond_the_paper(tmp_path):
    from report.registry import MEASURED

    beyond = (PaperClaim("BX.a", "paper's statement", "qualitative"), PaperClaim("BX.b", "how far", "not stated", beyond=True))
    exps = [_exp("BX", lambda ctx: {"BX.a": Finding("1 %", "yes"), "BX.b": Finding("up to 2 ms", MEASURED)}, beyond),
            _exp("BAD", lambda ctx: {"BAD.a": Finding("up to 2 ms", MEASURED)})]
    data = run_report(exps, tmp_path, quick=False, argv=[], progress=lambda line: None)
    rows = {r["id"]: r for r in data["claims"]}
    assert rows["BX.b"]["verdict"] == MEASURED and rows["BX.b"]["beyond"] and not rows["BX.a"]["beyond"]
    assert rows["BAD.a"]["verdict"] == "failed" and "claim of the paper" in rows["BAD.a"]["reason"]
    assert data["summary"] == {"yes": 1, "partly": 0, "consistent": 0, "no": 0, "failed": 1, "not run": 0, MEASURED: 1}
    html = (tmp_path / "index.html").read_text()
    claims_part, beyond_part = html.split("<h2>Beyond the paper</h2>")
    assert "BX.a" in claims_part.split("<h2>Claims</h2>")[1] and "up to 2 ms" in beyond_part.split("<h2>Figures")[0]
    assert "up to 2 ms" not in claims_part.split("<h2>Claims</h2>")[1]


def test_the_sweeps_beyond_the_paper_are_offline_and_run_before_the_network():
    ids = [e.id for e in EXPERIMENTS]
    kinds = {e.id: e.kind for e in EXPERIMENTS}
    assert kinds["B1"] == kinds["B2"] == "offline"
    assert max(ids.index("B1"), ids.index("B2")) < min(i for i, e in enumerate(EXPERIMENTS) if e.kind == "cyber")
    assert all(c.beyond or c.paper != "not stated" for e in EXPERIMENTS for c in e.claims)


def test_f5net_reads_its_case_from_the_scenario_file():
    """F5net's offline counterpart is built from what scenarios/paper/f5_inertia_100mw_battery.yaml sets."""
    from report import net_arrangement
    from report.exp_inertia_net import case

    c = case()  # the paper's comparison arrangement: the onshore 40 MVA SDViSC (host wt6_1)
    assert c["grid"] == {"h_grid": 5.0, "s_grid_mva": 1000.0}
    assert (c["h"], c["n_visc"], c["mw"], c["t_load"]) == (4.0, 1, 100.0, 1.0)
    assert c["batteries"] == ["wt6_1"] and c["soc_init"] == 0.5
    try:
        net_arrangement.choose(net_arrangement.CLUSTER3)  # the cluster-3 variant's file
        c = case()
    finally:
        net_arrangement.choose(net_arrangement.ONSHORE)
    assert (c["h"], c["n_visc"], c["mw"], c["t_load"]) == (4.0, 4, 100.0, 1.0)
    assert c["batteries"] == ["wt3_1", "wt3_2", "wt3_3", "wt3_4"] and c["soc_init"] == 0.5
