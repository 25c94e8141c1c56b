"""Boundaries searched, not sampled: a stability boundary in a continuous parameter (SCR) by
bisection, the smallest integer that suffices (number of SDViSCs) by binary search. The predicate is
assumed monotonic over the interval (stable on one side, not on the other); every evaluation is
kept as evidence."""

from __future__ import annotations

import bisect
from collections.abc import Callable
from dataclasses import dataclass, field

from scipy.optimize import bisect as scipy_bisect


@dataclass
class Boundary:
    value: float | None  # the boundary (None: the predicate does not change over the interval)
    bracket: tuple[float, float] | None  # the last interval known to hold the change
    evaluations: list[tuple[float, bool]] = field(default_factory=list)  # (x, predicate(x)) in call order
    note: str = ""


def threshold(predicate: Callable[[float], bool], lo: float, hi: float, xtol: float) -> Boundary:
    """The x in [lo, hi] where ``predicate`` changes, to within ``xtol`` (scipy's bisection on the
    predicate's sign). ``value`` is the middle of the final bracket."""
    memo: dict[float, bool] = {}
    evaluations: list[tuple[float, bool]] = []

    def evaluate(x: float) -> bool:
        if x not in memo:
            memo[x] = bool(predicate(x))
            evaluations.append((x, memo[x]))
        return memo[x]

    at_lo, at_hi = evaluate(lo), evaluate(hi)
    if at_lo == at_hi:
        return Boundary(None, None, evaluations, f"no change over [{lo:g}, {hi:g}]: predicate is {at_lo} at both ends")
    x0 = scipy_bisect(lambda x: 1.0 if evaluate(x) == at_hi else -1.0, lo, hi, xtol=xtol, maxiter=200)
    side_lo = min((x for x, v in evaluations if v == at_lo), key=lambda x: abs(x - x0))
    side_hi = min((x for x, v in evaluations if v == at_hi), key=lambda x: abs(x - x0))
    bracket = (min(side_lo, side_hi), max(side_lo, side_hi))
    return Boundary(0.5 * (bracket[0] + bracket[1]), bracket, evaluations)


def smallest_sufficient(predicate: Callable[[int], bool], lo: int, hi: int) -> Boundary:
    """The smallest n in [lo, hi] with ``predicate(n)`` true (binary search; needs false below it and
    true above it). ``value`` None if even ``hi`` does not suffice."""
    evaluations: list[tuple[float, bool]] = []

    def key(n: int) -> bool:
        ok = bool(predicate(n))
        evaluations.append((n, ok))
        return ok

    k = bisect.bisect_left(range(lo, hi + 1), True, key=key)
    if k > hi - lo:
        return Boundary(None, None, evaluations, f"not reached with up to {hi}")
    n = lo + k
    return Boundary(float(n), (float(n - 1), float(n)), evaluations)
