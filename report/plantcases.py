"""What the report reads from the offline farm runs: the farm cases themselves (plant/cases.py,
shared with the plant's tests), time windows, settling of V_pcc after a weak-grid event, t90."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from plant.cases import FIRST_VISC, bare_plant, sc_plant, visc_indices, visc_plant

__all__ = ["FIRST_VISC", "bare_plant", "sc_plant", "visc_indices", "visc_plant"]  # the farm cases, from plant/

FAULT_SLG = "single-phase-to-ground fault at the PCC"
V_BAND = 0.9  # p.u.: a weak-grid case "holds" (a usable operating point) when V_pcc settles at or above this
PTP_SETTLED = 0.02  # p.u.: peak-to-peak of V_pcc over the last second below this = settled


def window(r: dict, t0: float, t1: float) -> np.ndarray:
    return (r["t"] >= t0) & (r["t"] < t1)


@dataclass
class Settling:
    v_end: float  # V_pcc at the end [p.u.]
    ptp_last_s: float  # peak-to-peak of V_pcc over the last second [p.u.]
    v_min: float  # lowest V_pcc after the event [p.u.]
    finite: bool = True  # False: the simulation diverged (non-finite values)

    @property
    def settled(self) -> bool:
        """No sustained oscillation: what "stable" means in the weak-grid searches."""
        return self.finite and self.ptp_last_s < PTP_SETTLED

    @property
    def holds(self) -> bool:
        """Settled within the voltage band (a usable operating point)."""
        return self.settled and self.v_end >= V_BAND

    def describe(self) -> str:
        if not self.finite:
            return "diverged (non-finite V_pcc)"
        state = ("settles in the band" if self.holds else f"settles below {V_BAND} p.u." if self.settled
                 else "oscillates")
        return f"{state}: V_pcc end {self.v_end:.3f}, p-p last 1 s {self.ptp_last_s:.3f}, min {self.v_min:.3f}"


def settling(r: dict, t_event: float) -> Settling:
    t_end = r["t"][-1]
    last = window(r, t_end - 1.0, t_end + 1.0)
    after = r["t"] > t_event
    v = r["v_pcc"]
    return Settling(float(v[-1]), float(np.ptp(v[last])), float(v[after].min()), bool(np.all(np.isfinite(v))))


def t90(t: np.ndarray, y: np.ndarray, t0: float) -> float:
    """Time after t0 until y first covers 90 % of its total change."""
    y0 = y[np.searchsorted(t, t0) - 1]
    dy = y[-1] - y0
    k = np.nonzero((t > t0) & (np.abs(y - y0) >= 0.9 * abs(dy)))[0]
    return float(t[k[0]] - t0) if len(k) else float("nan")
