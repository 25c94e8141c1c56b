"""The plant linearised around a state: the Jacobian of ``Plant.rhs_real`` by central differences
(the slow terms held as they are; the plant's state and slow terms restored after). One function for
the report's mechanism checks (report/f7_mechanism.py) and the tests that check damping against it."""

from __future__ import annotations

import numpy as np


def jacobian(plant, y0: np.ndarray, rel_step: float = 1e-6, fixed_step: float | None = None) -> np.ndarray:
    """d rhs_real / d y at ``y0``: column k from y0 ± h_k e_k, h_k = rel_step · max(1, |y0_k|), or
    ``fixed_step`` for every k where given."""
    keep, slow = plant.state_real().copy(), plant.tb.slow
    y0 = np.asarray(y0, dtype=float)
    n = y0.size
    jac = np.empty((n, n))
    with np.errstate(all="ignore"):
        for k in range(n):
            h = fixed_step if fixed_step is not None else rel_step * max(1.0, abs(y0[k]))
            yp, ym = y0.copy(), y0.copy()
            yp[k] += h
            ym[k] -= h
            jac[:, k] = (plant.rhs_real(0.0, yp) - plant.rhs_real(0.0, ym)) / (2.0 * h)
    plant.set_state_real(keep)
    plant.tb.slow = slow
    return jac
