"""How close each candidate k of a calibration came (``time_scale: auto``, :mod:`scenarios.calibrate`).

A trial's verdict is pass/fail on the p99 of the answer times (:func:`scenarios.calibrate.shortfalls`);
this says by how much, in the terms a run is judged by afterwards (``summary.json`` → ``advice``:
over 1 % of a turbine's answers a sample late, or of the plant's steps late):

* ``within_one_sample``: per turbine, the fraction of its answers (CTRL kernel receive stamp counted
  from the start of the step that sent its MEAS) that came within one sample period — worst turbine
  (with its name) and median over the turbines; a MEAS never answered counts as late;
* ``within_limit``: the same against the pilot's own limit (``ROUND_TRIP_LIMIT_STEPS`` of a sample);
* ``late_steps``: the pilot's steps that began more than one period after their scheduled time;
* ``limit_used``: the worst turbine's p99 answer time over the limit (≤ 1 passes; 1.04 = 4 % over).

Pure: answer times and step lateness in, a dict out (:func:`closeness`), and one line per trial for
the terminal (:func:`candidate_line`).
"""

from __future__ import annotations

import numpy as np


def _fractions(answer_ms: dict[str, list[float]], limit_ms: float, expected: int) -> dict[str, float]:
    """Per turbine, the share of ``expected`` answers that came within ``limit_ms``."""
    return {wt: float(np.count_nonzero(np.asarray(v, dtype=float) <= limit_ms)) / expected
            for wt, v in answer_ms.items()}


def _worst_and_median(fractions: dict[str, float]) -> dict:
    if not fractions:
        return {"worst": None, "worst_turbine": None, "median": None}
    worst = min(fractions, key=fractions.__getitem__)
    return {"worst": round(fractions[worst], 4), "worst_turbine": worst,
            "median": round(float(np.median(list(fractions.values()))), 4)}


def closeness(answer_ms: dict[str, list[float]], expected: int, period_wall_s: float, limit_wall_s: float,
              lateness_s, worst_p99_wall_s: float | None) -> dict:
    """How close a trial came. ``answer_ms``: per turbine, each answer's time after its step began
    (wall ms); ``expected``: MEAS sent per turbine (the missing ones count as late); ``period_wall_s``:
    one sample of wall time at this k; ``limit_wall_s``: the pilot's answer limit; ``lateness_s``: each
    step's start after its schedule (wall s); ``worst_p99_wall_s``: the worst turbine's p99 answer time."""
    expected = max(1, int(expected))
    lateness = np.asarray(lateness_s, dtype=float)
    return {
        "within_one_sample": _worst_and_median(_fractions(answer_ms, period_wall_s * 1e3, expected)),
        "within_limit": _worst_and_median(_fractions(answer_ms, limit_wall_s * 1e3, expected)),
        "late_steps": int(np.count_nonzero(lateness > period_wall_s)),
        "max_lateness_samples": round(float(lateness.max()) / period_wall_s, 2) if lateness.size else 0.0,
        "limit_used": None if worst_p99_wall_s is None else round(worst_p99_wall_s / limit_wall_s, 3),
    }


def candidate_line(trial: dict) -> str:
    """One trial in a few words: e.g. ``k = 8 fell short: p99 104 % of the limit; worst turbine wt5_6
    97.2 % within one sample (median 98.9 %); 0 late steps``."""
    verdict = "passed" if trial["ok"] else "fell short"
    near = trial.get("closeness")
    if not near:
        return f"k = {trial['k']:g} {verdict}"
    one = near["within_one_sample"]
    used = near["limit_used"]
    parts = [f"p99 {used:.0%} of the limit" if used is not None else "no answer time"]
    if one["worst"] is not None:
        parts.append(f"worst turbine {one['worst_turbine']} {one['worst']:.1%} within one sample "
                     f"(median {one['median']:.1%})")
    parts.append(f"{near['late_steps']} late step{'s' * (near['late_steps'] != 1)}")
    return f"k = {trial['k']:g} {verdict}: " + "; ".join(parts)


def candidates_line(trials: list[dict]) -> str:
    """Every trial of a calibration, smallest k first, in one line (``calibration.candidates``)."""
    return " | ".join(candidate_line(t) for t in sorted(trials, key=lambda t: t["k"]))


def candidates(trials: list[dict]) -> list[dict]:
    """Every trial's closeness in a few numbers, smallest k first (``summary.json`` → ``time.calibration.candidates``)."""
    rows = []
    for t in sorted(trials, key=lambda t: t["k"]):
        near = t.get("closeness") or {}
        one = near.get("within_one_sample") or {}
        rows.append({"k": t["k"], "ok": t["ok"], "limit_used": near.get("limit_used"),
                     "within_one_sample_worst": one.get("worst"), "worst_turbine": one.get("worst_turbine"),
                     "within_one_sample_median": one.get("median"), "late_steps": near.get("late_steps"),
                     "why_not": t.get("why_not", [])})
    return rows
