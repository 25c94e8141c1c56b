"""How a verdict is computed from measured numbers: stated tolerances, no judgement by hand."""

from __future__ import annotations

import math
from collections.abc import Sequence

# Relative tolerances for a number the paper prints: within YES of the paper's value is reproduced,
# within PARTLY is reproduced in kind (same direction and order of magnitude), else not.
REL_YES = 0.10
REL_PARTLY = 0.35
# A number reached only through a parameter the paper does not state (a fault resistance, a fault type
# where the text allows two): "consistent" when the value that reproduces it lies in a cited range —
# reported with that value and the range, never counted as reproduced.
CONSISTENT = "consistent"


def relative_error(measured: float, paper: float) -> float:
    """|measured − paper| / |paper| (inf for a non-finite measurement)."""
    if not math.isfinite(measured):
        return math.inf
    return abs(measured - paper) / abs(paper)


def close_to(measured: float, paper: float, rel_yes: float = REL_YES, rel_partly: float = REL_PARTLY) -> str:
    """yes / partly / no by the relative error against the paper's value."""
    err = relative_error(measured, paper)
    return "yes" if err <= rel_yes else "partly" if err <= rel_partly else "no"


def change_close_to(before: float, after: float, paper_before: float, paper_after: float,
                    rel_yes: float = REL_YES, rel_partly: float = REL_PARTLY) -> str:
    """For a claimed step (e.g. 0.97 → 1.02): yes / partly / no by the relative error of the change;
    a change of the wrong sign is "no"."""
    paper_change = paper_after - paper_before
    change = after - before
    if change * paper_change <= 0:
        return "no"
    return close_to(change, paper_change, rel_yes, rel_partly)


def holds(condition: bool, partly: bool = False) -> str:
    """A qualitative claim: yes if it holds, partly if only the weaker ``partly`` holds, else no."""
    return "yes" if condition else "partly" if partly else "no"


def ordered(values: Sequence[float], increasing: bool = True, strict: bool = True) -> bool:
    """Whether the values run in the stated direction."""
    pairs = list(zip(values, values[1:]))
    if increasing:
        return all(b > a if strict else b >= a for a, b in pairs)
    return all(b < a if strict else b <= a for a, b in pairs)


def consistent_within(value: float | None, lo: float, hi: float) -> str:
    """For a printed number only an unstated parameter reaches: CONSISTENT when the parameter's value
    that reproduces it (``value``; None: no value reproduces it) lies in the cited range [lo, hi], else
    "no"."""
    return CONSISTENT if value is not None and math.isfinite(value) and lo <= value <= hi else "no"
