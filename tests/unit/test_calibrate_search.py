"""The calibration's search over time scales: from a remembered start it finds the same smallest
passing k as the plain upward scan, in fewer trials (the property monotonic in k)."""

from __future__ import annotations

import pytest

from scenarios.calibrate import CANDIDATES, choose, search


def _trial_passing_from(threshold: float, tried: list):
    def trial(k: float) -> dict:
        tried.append(k)
        return {"k": k, "ok": k >= threshold}
    return trial


@pytest.mark.parametrize("threshold", [1, 2, 8, 16, 64, 128])
@pytest.mark.parametrize("start", [None, 1, 4, 16, 64])
def test_every_start_finds_the_smallest_passing_k(threshold, start):
    plain, hinted = [], []
    expected = choose(search(_trial_passing_from(threshold, plain)))
    found = choose(search(_trial_passing_from(threshold, hinted), start))
    assert found == expected
    assert expected == ((float(threshold), True) if threshold <= 64 else (64.0, False))
    assert len(set(hinted)) == len(hinted)  # no k tried twice


def test_a_good_start_takes_two_trials_and_the_plain_scan_more():
    plain, hinted = [], []
    search(_trial_passing_from(16, plain))
    search(_trial_passing_from(16, hinted), 16)
    assert plain == [1, 2, 4, 8, 16] and hinted == [16, 8]
    assert CANDIDATES[0] == 1  # k = 1 is tried first when there is no start
