"""Small statistics helpers shared by the services (delay percentiles)."""

from __future__ import annotations

import numpy as np


def delay_summary(samples_ms) -> dict | None:
    """p50/p99/max/mean of one-way delays in ms, or None without samples."""
    if len(samples_ms) == 0:
        return None
    a = np.asarray(samples_ms, dtype=float)
    return {"n": int(a.size), "p50": float(np.percentile(a, 50)), "p99": float(np.percentile(a, 99)),
            "max": float(a.max()), "mean": float(a.mean())}
