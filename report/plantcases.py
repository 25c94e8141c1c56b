"""What the report reads from the offline farm runs: the farm cases themselves (plant/cases.py,
shared with the plant's tests), time windows, t90 (the weak-grid
stability criterion is report/stability.py)."""

from __future__ import annotations

import numpy as np

from plant.cases import FIRST_VISC, bare_plant, sc_plant, visc_indices, visc_plant

__all__ = ["FIRST_VISC", "bare_plant", "sc_plant", "visc_indices", "visc_plant"]  # the farm cases, from plant/

FAULT_SLG = "single-phase-to-ground fault at the PCC"


def window(r: dict, t0: float, t1: float) -> np.ndarray:
    return (r["t"] >= t0) & (r["t"] < t1)


def t90(t: np.ndarray, y: np.ndarray, t0: float) -> float:
    """Time after t0 until y first covers 90 % of its total change."""
    y0 = y[np.searchsorted(t, t0) - 1]
    dy = y[-1] - y0
    k = np.nonzero((t > t0) & (np.abs(y - y0) >= 0.9 * abs(dy)))[0]
    return float(t[k[0]] - t0) if len(k) else float("nan")
