"""The paper's ten printed magnitudes (issue 39, item 9), each counted once: the quoted sentence, the
claim whose finding judges it, and — from that finding, never typed — the reading (bus, phase,
sequence, RMS or instantaneous, device), the value, the alternatives beside it and the verdict. An
experiment gives them in ``Finding.measured["printed"]`` (``reading``, ``value``, ``alternatives``
and, where the magnitude is only part of the claim, its own ``verdict``); otherwise the claim's row
is used as it stands. The headline "N of 10 within 10 %" counts the "yes" verdicts: a magnitude within
10 % of the paper's, the one bound (F6 "> 0.7") held; "consistent" (reached only through an unstated
parameter inside a cited range) is counted apart, never as reproduced.

Per model (issue 40): each magnitude is read on the phasor plant (its paper row, above) and, where the
EMT backend covers it, on the EMT model (``emt``: the EMT row whose ``measured["printed"]`` carries the EMT
value's own reading, value and verdict against the paper, by the same rule as the phasor row). The
headline counts each model apart — never the better of the two."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass


@dataclass(frozen=True)
class Printed:
    id: str  # short name
    claim: str  # the claim id whose finding judges it
    paper: str  # as printed
    quote: str  # the paper's sentence (Section IV)
    reading: str  # how the experiment reads it when its finding does not say
    bound: bool = False  # a bound ("> 0.7"), judged held or not
    emt: str = ""  # the EMT row that reads it on the EMT backend ("": the EMT backend does not cover it)


PRINTED = (
    Printed("F3 ≈ 1.035", "F3.a", "≈ 1.035 p.u.", "both the SC and SDViSC boost the voltage around 1.035 p.u. finally",
            "each device's own terminal, V1 RMS, final value", emt="EMT.F3"),
    Printed("F6 ≈ 4 p.u.", "F6.a", "4 p.u.", "the SC offers a short-circuit current that rises to 4 p.u.",
            "SC phase current, first peak", emt="EMT.F6a"),
    Printed("F6 > 0.7", "F6.b", "> 0.7 p.u.", "the residual voltage is above 0.7 p.u.",
            "SC terminal, V1 RMS during the fault", bound=True, emt="EMT.F6b"),
    Printed("F6 SDViSC ≈ 0.6", "F6.d", "≈ 0.6 p.u.", "The residual voltage is about 0.6 p.u., which is lower than "
            "that of the SC", "SDViSC terminal, V1 RMS during the fault", emt="EMT.F6d"),
    Printed("F7 none 2.04", "F7.a", "SCR 2.04", "When there is no SC or SDViSC, the system is unstable ... when the SCR "
            "decreases to 2.04", "SCR step boundary, no device", emt="EMTW.F7a"),
    Printed("F7 SC 1.58", "F7.b", "SCR 1.58", "The system still loses stability when the SCR decreased to 1.58 due to "
            "the limited capability of SC", "SCR step boundary, SC", emt="EMTW.F7b"),
    Printed("F8 0.97 → 1.02", "F8.a", "0.97 → 1.02 p.u.", "before the deployment of SDViSC (before 1s), the PCC "
            "voltage is 0.97 p.u. ... the PCC voltage is accordingly boosted to 1.02 p.u.", "PCC, V1 RMS, rise", emt="EMTF8.a"),
    Printed("F8 0.4", "F8.c", "0.4 p.u.", "without SDViSCs, the PCC voltage drops to 0.4 p.u. after the fault "
            "(a phase-to-ground fault that occurred at the grid side at 1s)", "PCC during the fault", emt="EMTF8.c"),
    Printed("C1 ≈ 0.1 s", "C1.b", "≈ 0.1 s", "currents and voltages of SDViSCs can be stabilized in a short time "
            "(i.e., within around 0.1s) after the plug operation", "the plugged SDViSC's current and voltage"),
    Printed("F9 until ≈ 3 s", "F9.d", "≈ 3 s", "this weak grid can maintain stable until 3s. However ... the system "
            "still deviates from the nominal operating point after 3s (caption: WT1_CS1: Wind Turbine 1 in "
            "Cluster 1)", "as the F9.d row reads it", emt="EMTW.F9a"),
)


def table(rows: list[dict]) -> list[dict]:
    """One entry per printed magnitude from the claim rows (``report.run.claim_rows``): the phasor plant's
    reading at the top level (as before issue 40), the EMT backend's under ``emt``."""
    by_id = {r["id"]: r for r in rows}
    out = []
    for p in PRINTED:
        row = by_id.get(p.claim)
        given = (row or {}).get("measured", {}).get("printed", {}) if row else {}
        verdict = given.get("verdict", row["verdict"]) if row else "not run"
        out.append({"magnitude": p.id, "claim": p.claim, "paper": p.paper, "quote": p.quote, "bound": p.bound,
                    "reading": given.get("reading", p.reading),
                    "value": given.get("value", row["testbed"] if row else "—"),
                    "alternatives": given.get("alternatives", {}), "verdict": verdict, "emt": _emt_entry(p, by_id)})
    return out


NOT_ON_EMT = "not on EMT"
UNCOUNTED = ("not run", "failed", NOT_ON_EMT)


def _emt_entry(p: Printed, by_id: dict) -> dict:
    """The EMT backend's reading of ``p``: its row's ``printed`` (a verdict against the paper, not the row's
    consistency verdict); "not on EMT" where the backend does not cover it, "not run" where its row is
    missing, "failed" where it failed or gives no reading."""
    if not p.emt:
        return {"claim": "", "reading": "", "value": "—", "alternatives": {}, "verdict": NOT_ON_EMT}
    row = by_id.get(p.emt)
    if row is None:
        return {"claim": p.emt, "reading": "", "value": "—", "alternatives": {}, "verdict": "not run"}
    given = row.get("measured", {}).get("printed") or {}
    return {"claim": p.emt, "reading": given.get("reading", ""), "value": given.get("value", row["testbed"]),
            "alternatives": given.get("alternatives", {}), "verdict": given.get("verdict", "failed")}


def _count(verdicts: list[str]) -> dict:
    counts = Counter(verdicts)
    return {"within_10pct": counts.get("yes", 0), "of": len(verdicts),
            "evaluated": sum(v not in UNCOUNTED for v in verdicts), "counts": dict(counts)}


def headline(entries: list[dict]) -> dict:
    """"N of 10 within 10 %" (a magnitude within 10 %, the bound held) per model: the phasor plant's at the
    top level (the report's headline since issue 39), both under ``per_model``; only the magnitudes whose
    experiment ran are ``evaluated``. Never the better of the two models: each is counted on its own."""
    phasor = _count([e["verdict"] for e in entries])
    emt = _count([e.get("emt", {}).get("verdict", NOT_ON_EMT) for e in entries])
    rest = ", ".join(f"{n} {v}" for v, n in phasor["counts"].items() if v != "yes")
    emt_rest = ", ".join(f"{n} {v}" for v, n in emt["counts"].items() if v != "yes")
    text = (f"{phasor['within_10pct']} of {phasor['of']} printed magnitudes within 10 % (the bound F6 > 0.7 counted as "
            f"held or not){'; ' + rest if rest else ''}")
    emt_text = (f"EMT backend: {emt['within_10pct']} of {emt['of']} printed magnitudes within 10 % ({emt['evaluated']} "
                f"read on EMT{'; ' + emt_rest if emt_rest else ''})")
    return {**phasor, "text": text, "per_model": {"phasor": {**phasor, "text": text},
                                                 "emt": {**emt, "text": emt_text}}}
