"""The printed-magnitudes table (report/printed.py): ten entries, each computed from its claim's row
(the finding's own ``printed`` reading where it gives one), and the headline counting each once."""

from __future__ import annotations

from report import printed
from report.catalogue import EXPERIMENTS
from report.registry import VERDICTS, Finding
from report.verdicts import CONSISTENT, consistent_within


def _row(cid: str, verdict: str, testbed: str = "x", measured: dict | None = None) -> dict:
    return {"id": cid, "verdict": verdict, "testbed": testbed, "measured": measured or {}}


def test_the_ten_printed_magnitudes_name_registered_claims():
    claims = {c.id for e in EXPERIMENTS for c in e.claims}
    assert len(printed.PRINTED) == 10 and len({p.id for p in printed.PRINTED}) == 10
    assert {p.claim for p in printed.PRINTED} <= claims
    assert [p.claim for p in printed.PRINTED if p.bound] == ["F6.b"]


def test_entries_come_from_the_findings_and_the_headline_counts_yes_once():
    rows = [_row("F3.a", "yes"), _row("F6.a", "partly"), _row("F6.b", "yes"),
            _row("F6.d", "partly", measured={"printed": {"reading": "terminal", "value": 0.9, "verdict": "no",
                                                          "alternatives": {"PCC": 0.595}}}),
            _row("F8.c", CONSISTENT), _row("F8.a", "no")]
    table = printed.table(rows)
    by = {e["claim"]: e for e in table}
    assert by["F6.d"]["verdict"] == "no" and by["F6.d"]["reading"] == "terminal"  # the magnitude's own verdict
    assert by["F6.d"]["alternatives"] == {"PCC": 0.595}
    assert by["F7.a"]["verdict"] == "not run" and by["F3.a"]["value"] == "x"
    head = printed.headline(table)
    assert head["within_10pct"] == 2 and head["of"] == 10 and head["evaluated"] == 6
    assert head["counts"][CONSISTENT] == 1  # consistent is not counted as within 10 %
    assert head["text"].startswith("2 of 10 printed magnitudes within 10 %")


def test_consistent_is_a_verdict_and_needs_its_value_in_the_cited_range():
    assert CONSISTENT in VERDICTS
    assert consistent_within(16.8, 0.0, 50.0) == CONSISTENT
    assert consistent_within(60.0, 0.0, 50.0) == "no" and consistent_within(None, 0.0, 50.0) == "no"
    Finding("R_f 16.8 Ω gives 0.4", CONSISTENT, "only through an unstated fault resistance")


def test_each_model_is_counted_on_its_own():
    """Issue 40: the EMT backend's reading of a magnitude is its EMT row's own ``printed`` verdict (not the
    row's phasor-vs-EMT consistency verdict), and the headline counts the two models apart."""
    rows = [_row("F3.a", "no"), _row("F6.b", "yes"),
            _row("EMT.F3", "yes", measured={"printed": {"reading": "EMT terminal", "value": "1.032", "verdict": "yes"}}),
            _row("EMT.F6b", "yes", measured={"printed": {"reading": "EMT terminal", "value": "0.69", "verdict": "no"}}),
            _row("EMTF8.a", "no")]  # an EMT row without a reading of the magnitude: failed, not its own verdict
    table = printed.table(rows)
    by = {e["claim"]: e for e in table}
    assert by["F3.a"]["verdict"] == "no" and by["F3.a"]["emt"]["verdict"] == "yes"
    assert by["F6.b"]["verdict"] == "yes" and by["F6.b"]["emt"]["verdict"] == "no"
    assert by["F8.a"]["emt"]["verdict"] == "failed" and by["C1.b"]["emt"]["verdict"] == printed.NOT_ON_EMT
    head = printed.headline(table)
    assert head["within_10pct"] == 1 and head["per_model"]["phasor"]["within_10pct"] == 1
    assert head["per_model"]["emt"]["within_10pct"] == 1  # not 2: never the better of the two per magnitude
    assert head["per_model"]["emt"]["evaluated"] == 2  # the failed reading is not evaluated
    assert head["per_model"]["emt"]["text"].startswith("EMT backend: 1 of 10")


def test_every_emt_reading_names_a_registered_emt_claim():
    claims = {c.id for e in EXPERIMENTS for c in e.claims}
    named = [p.emt for p in printed.PRINTED if p.emt]
    assert len(named) >= 5 and set(named) <= claims
