"""What the sweeps beyond the paper (issue 9: network delay B1, sampling period B2) judge by: the
stated thresholds, the "unstable" criterion and where along a sweep a property first fails. Pure
functions on numbers (tests/unit/test_report.py checks them on made-up curves)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

ACCEPT_PCT = 5.0  # % of the HD trace's range: worst RMS deviation of |V_pcc|, Q, δ, E "within" the HD ViSC
# (F1's "partly" bound: the same behaviour in kind; F1's 1 % is drawn in the figures too)
OSC_WINDOW_S = 0.5  # the last this-many seconds of a run are where a sustained oscillation is looked for
OSC_PTP_PU = 0.02  # p.u.: peak-to-peak of |V_pcc| there this much above the HD ViSC's = sustained oscillation
UNSTABLE_CRITERION = (f"unstable = a ViSC converter trips (remote-mode over-current protection, |i| > 2.0 p.u.), "
                      f"or the plant's values stop being finite, or |V_pcc| oscillates at the end: its peak-to-peak "
                      f"over the last {OSC_WINDOW_S} s exceeds the HD ViSC's by more than {OSC_PTP_PU} p.u.")


def worst_pct(cmp: dict[str, dict[str, float]]) -> float:
    """The worst of the quantities' RMS deviation / HD range [%] (``plant.cosim.compare``); inf if any
    is not finite."""
    values = [c["rms_over_range_pct"] for c in cmp.values()]
    return max(values) if all(math.isfinite(v) for v in values) else math.inf


def instability(t: np.ndarray, v_pcc: np.ndarray, v_pcc_hd: np.ndarray, trips: Sequence[int] = (),
                trip_t: float = math.nan) -> str | None:
    """Why a run counts as unstable (UNSTABLE_CRITERION), None if it does not."""
    if np.any(np.asarray(trips) > 0):
        return f"converter trip at {trip_t:.3f} s" if math.isfinite(trip_t) else "converter trip"
    if not np.all(np.isfinite(v_pcc)):
        k = int(np.argmin(np.isfinite(np.asarray(v_pcc).reshape(len(t), -1)).all(axis=1)))
        return f"non-finite values from {t[k]:.3f} s"
    last = t > t[-1] - OSC_WINDOW_S
    ptp, ptp_hd = float(np.ptp(v_pcc[last])), float(np.ptp(v_pcc_hd[last]))
    if ptp > ptp_hd + OSC_PTP_PU:
        return f"|V_pcc| oscillates: peak-to-peak {ptp:.3f} p.u. over the last {OSC_WINDOW_S} s (HD {ptp_hd:.3f})"
    return None


@dataclass(frozen=True)
class Crossing:
    """Where along a sweep (values ascending) a property first fails."""

    first_bad: float | None  # the first swept value at which it fails (None: it never does)
    last_good: float | None  # the swept value before that (None: it fails from the first one)
    swept: tuple[float, ...]
    recovers: bool = False  # it holds again at a larger swept value (the sweep is not monotonic there)

    def describe(self, holds: str, fails: str, unit: str, scale: float = 1.0) -> str:
        """e.g. "within 5 % up to 0.5 ms, not from 1 ms"; ``scale`` converts the swept values to ``unit``."""
        def v(x: float) -> str:
            return f"{x * scale:g} {unit}"

        if self.first_bad is None:
            return f"{holds} over the whole sweep ({v(self.swept[0])} to {v(self.swept[-1])})"
        if self.last_good is None:
            return f"never {holds} ({v(self.swept[0])} to {v(self.swept[-1])})"
        upto = "only at" if self.last_good == self.swept[0] else "up to"
        text = f"{holds} {upto} {v(self.last_good)}, {fails} from {v(self.first_bad)}"
        return text + (" (holds again at a larger value)" if self.recovers else "")


def crossing(values: Sequence[float], bad: Sequence[bool]) -> Crossing:
    """The first of ``values`` (sorted ascending here) at which ``bad`` is true, and the one before."""
    if len(values) != len(bad) or not len(values):
        raise ValueError("one flag per swept value, at least one")
    order = sorted(range(len(values)), key=lambda i: values[i])
    xs = tuple(float(values[i]) for i in order)
    flags = [bool(bad[i]) for i in order]
    if not any(flags):
        return Crossing(None, xs[-1], xs)
    k = flags.index(True)
    return Crossing(xs[k], xs[k - 1] if k else None, xs, recovers=not all(flags[k:]))
