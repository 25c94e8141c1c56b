"""report.compare_claims: a claim unchanged is not listed; added, removed and changed ones are."""

from report.compare_claims import differences


def _claims(*rows):
    return {"claims": [{"id": i, "verdict": v, "testbed": t} for i, v, t in rows]}


def test_only_what_differs_is_listed():
    old = _claims(("F1.a", "partly", "3.38 %"), ("F2.a", "no", "x"), ("C2.b", "yes", "43.8 ms"))
    new = _claims(("F1.a", "partly", "3.38 %"), ("C2.b", "yes", "50.5 ms"), ("LAW1.a", "measured", "1.29 %"))
    lines = differences(old, new)
    assert lines[0].startswith("~ C2.b: yes -> yes") and "43.8 ms" in lines[0] and "50.5 ms" in lines[0]
    assert lines[1] == "- F2.a: no"
    assert lines[2] == "+ LAW1.a: measured | 1.29 %"
    assert len(lines) == 3  # F1.a identical: not listed


def test_identical_reports_have_no_differences():
    same = _claims(("F1.a", "partly", "3.38 %"))
    assert differences(same, same) == []
