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
    assert data["summary"] == {"yes": 0, "partly": 1, "no": 0, "failed": 2, "not run": 1}
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
