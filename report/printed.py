"""The paper's ten printed magnitudes (issue 39, item 9), each counted once: the quoted sentence, the
claim whose finding judges it, and — from that finding, never typed — the reading (bus, phase,
sequence, RMS or instantaneous, device), the value, the alternatives beside it and the verdict. An
experiment gives them in ``Finding.measured["printed"]`` (``reading``, ``value``, ``alternatives``
and, where the magnitude is only part of the claim, its own ``verdict``); otherwise the claim's row
is used as it stands. The headline "N of 10 within 10 %" counts the "yes" verdicts: a magnitude within
10 % of the paper's, the one bound (F6 "> 0.7") held; "consistent" (reached only through an unstated
parameter inside a cited range) is counted apart, never as reproduced."""

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


PRINTED = (
    Printed("F3 ≈ 1.035", "F3.a", "≈ 1.035 p.u.", "both the SC and SDViSC boost the voltage around 1.035 p.u. finally",
            "each device's own terminal, V1 RMS, final value"),
    Printed("F6 ≈ 4 p.u.", "F6.a", "4 p.u.", "the SC offers a short-circuit current that rises to 4 p.u.",
            "SC phase current, first peak"),
    Printed("F6 > 0.7", "F6.b", "> 0.7 p.u.", "the residual voltage is above 0.7 p.u.",
            "SC terminal, V1 RMS during the fault", bound=True),
    Printed("F6 SDViSC ≈ 0.6", "F6.d", "≈ 0.6 p.u.", "The residual voltage is about 0.6 p.u., which is lower than "
            "that of the SC", "SDViSC terminal, V1 RMS during the fault"),
    Printed("F7 none 2.04", "F7.a", "SCR 2.04", "When there is no SC or SDViSC, the system is unstable ... when the SCR "
            "decreases to 2.04", "SCR step boundary, no device"),
    Printed("F7 SC 1.58", "F7.b", "SCR 1.58", "The system still loses stability when the SCR decreased to 1.58 due to "
            "the limited capability of SC", "SCR step boundary, SC"),
    Printed("F8 0.97 → 1.02", "F8.a", "0.97 → 1.02 p.u.", "before the deployment of SDViSC (before 1s), the PCC "
            "voltage is 0.97 p.u. ... the PCC voltage is accordingly boosted to 1.02 p.u.", "PCC, V1 RMS, rise"),
    Printed("F8 0.4", "F8.c", "0.4 p.u.", "without SDViSCs, the PCC voltage drops to 0.4 p.u. after the fault "
            "(a phase-to-ground fault that occurred at the grid side at 1s)", "PCC during the fault"),
    Printed("C1 ≈ 0.1 s", "C1.b", "≈ 0.1 s", "currents and voltages of SDViSCs can be stabilized in a short time "
            "(i.e., within around 0.1s) after the plug operation", "the plugged SDViSC's current and voltage"),
    Printed("F9 until ≈ 3 s", "F9.d", "≈ 3 s", "this weak grid can maintain stable until 3s. However ... the system "
            "still deviates from the nominal operating point after 3s (caption: WT1_CS1: Wind Turbine 1 in "
            "Cluster 1)", "as the F9.d row reads it"),
)


def table(rows: list[dict]) -> list[dict]:
    """One entry per printed magnitude from the claim rows (``report.run.claim_rows``)."""
    by_id = {r["id"]: r for r in rows}
    out = []
    for p in PRINTED:
        row = by_id.get(p.claim)
        given = (row or {}).get("measured", {}).get("printed", {}) if row else {}
        verdict = given.get("verdict", row["verdict"]) if row else "not run"
        out.append({"magnitude": p.id, "claim": p.claim, "paper": p.paper, "quote": p.quote, "bound": p.bound,
                    "reading": given.get("reading", p.reading),
                    "value": given.get("value", row["testbed"] if row else "—"),
                    "alternatives": given.get("alternatives", {}), "verdict": verdict})
    return out


def headline(entries: list[dict]) -> dict:
    """"N of 10 within 10 %" (a magnitude within 10 %, the bound held), with the other verdicts' counts;
    only the magnitudes whose experiment ran are in ``evaluated``."""
    counts = Counter(e["verdict"] for e in entries)
    n_yes = counts.get("yes", 0)
    evaluated = sum(e["verdict"] not in ("not run", "failed") for e in entries)
    rest = ", ".join(f"{n} {v}" for v, n in counts.items() if v != "yes")
    return {"within_10pct": n_yes, "of": len(entries), "evaluated": evaluated, "counts": dict(counts),
            "text": f"{n_yes} of {len(entries)} printed magnitudes within 10 % (the bound F6 > 0.7 counted as "
                    f"held or not){'; ' + rest if rest else ''}"}
