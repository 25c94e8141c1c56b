"""The fixed-step integrator of the plant: one ETD2 update, used wherever a step is taken.

Exponential time differencing RK2 (Cox-Matthews ETD2RK) with a diagonal linear part -c per state
entry: c = OMEGA0 kpc / lf on the filter current of turbines with a local current loop (the closed
loop pole), c = 0 elsewhere, where the update is Heun's method. With E = exp(-c h),
phi1 = (1 - E)/c, phi2 = (E - 1 + c h)/(c^2 h) (c = 0: phi1 = h, phi2 = h/2) the textbook form
a = E X + phi1 (k1 + c X), X+ = a + phi2 (k2 + c a - k1 - c X) becomes, since phi1 c = 1 - E,

    a  = X + phi1 k1                      (predict)
    X+ = a + phi2 (k2 - E k1)             (correct)

``etd2_predict``/``etd2_correct`` are that update, compiled; the compiled plant step
(plant/kernels.py) calls them, and so does ``Plant.step`` for every other case (on the complex
plant state and, with c = 0, on the ViSC law states). ``method="rk2"`` is the same update with
c = 0 everywhere; ``method="rk4"`` (classical RK4, ``rk4_step``) is kept as an alternative.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def etd2_predict(x, k1, phi1, out):
    """out = x + phi1 k1 (flat float arrays; a complex state as its float view)."""
    for j in range(x.size):
        out[j] = phi1[j] * k1[j] + x[j]


@njit(cache=True)
def etd2_correct(a, k1, k2, e, phi2, out):
    """out = a + phi2 (k2 - E k1) (flat float arrays)."""
    for j in range(a.size):
        out[j] = a[j] + (k2[j] - e[j] * k1[j]) * phi2[j]


class Etd2Coefficients:
    """E, phi1, phi2 per float entry of a state (a complex entry's two floats share them);
    ``rows`` stacks them (3, m) for the compiled step."""

    def __init__(self, c, h: float, complex_state: bool = True):
        c = np.asarray(c, dtype=float)
        ch = c * h
        e = np.exp(-ch)
        safe = np.where(c > 0, c, 1.0)
        phi1 = np.where(c > 0, (1.0 - e) / safe, h)
        phi2 = np.where(c > 0, (e - 1.0 + ch) / (safe * safe * h), 0.5 * h)
        rows = np.stack([e, phi1, phi2])
        self.rows = np.repeat(rows, 2, axis=1) if complex_state else rows
        self.e, self.phi1, self.phi2 = self.rows


def _flat(x) -> np.ndarray:
    x = np.ascontiguousarray(x).reshape(-1)
    return x.view(np.float64) if x.dtype == np.complex128 else x


def predict(x, k1, coef: Etd2Coefficients):
    """a = x + phi1 k1 as a new array (x: the complex plant state or the real law state)."""
    out = np.empty_like(x)
    etd2_predict(_flat(x), _flat(k1), coef.phi1, _flat(out))
    return out


def correct(a, k1, k2, coef: Etd2Coefficients):
    """X+ = a + phi2 (k2 - E k1) as a new array."""
    out = np.empty_like(a)
    etd2_correct(_flat(a), _flat(k1), _flat(k2), coef.e, coef.phi2, _flat(out))
    return out


def rk4_step(f, X, xl, k1, l1, h: float):
    """Classical RK4 from the first stage (k1, l1); ``f(X, xl) -> (dX, dxl)``; xl may be None."""
    def axpy(x, a, dx):
        return None if x is None else x + a * dx
    k2, l2 = f(X + (0.5 * h) * k1, axpy(xl, 0.5 * h, l1))
    k3, l3 = f(X + (0.5 * h) * k2, axpy(xl, 0.5 * h, l2))
    k4, l4 = f(X + h * k3, axpy(xl, h, l3))
    X = X + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    if xl is not None:
        xl = xl + (h / 6.0) * ((l1 + l4) + 2.0 * (l2 + l3))
    return X, xl
