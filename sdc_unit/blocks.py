"""Discretised low-order blocks of the SDC unit, vectorised over N instances.

Three methods:

* ``tustin``: bilinear transform s = K (1 - z^-1)/(1 + z^-1), K = 2/Ts, recursive (direct form I)
  difference equations whose coefficients equal ``scipy.signal.cont2discrete(..., 'bilinear')``.
* ``trapezoid_cumulative``: the trapezoidal rule written with an explicit running sum of all past
  inputs (paper eq. 13); the same linear map as Tustin in exact arithmetic, kept so the rounding
  growth of the running sum is real (float32).
* ``euler``: forward Euler on the state-space form.

All state and arithmetic use the block's ``dtype`` (float64 or float32): coefficients are computed
in float64 once and stored in ``dtype``, as on a DSP. Every ``step`` takes an optional boolean
``mask``: states are only committed where the mask is True (outputs are computed for all).

Each block keeps its states in ``self.s`` (name -> array of shape (N,)), so ``snapshot``/``restore``
are generic. Here: the base :class:`Block`, the PIs and the first-order blocks; the swing equation
(eq. 1, 15) is in :mod:`sdc_unit.swing`.
"""

from __future__ import annotations

import numpy as np

METHODS = ("tustin", "trapezoid_cumulative", "euler")


# --------------------------------------------------------------------------- coefficients
def tustin_pi_coeffs(kp, ki, ts):
    """Tustin PI K_p + K_i/s: y(k) = y(k-1) + b0 e(k) + b1 e(k-1).

    Returns (b0, b1) = (K_p + K_i Ts/2, K_i Ts/2 - K_p); the denominator is (1, -1).
    """
    kp = np.asarray(kp, dtype=float)
    ki = np.asarray(ki, dtype=float)
    return kp + ki * ts / 2.0, ki * ts / 2.0 - kp


def tustin_first_order_coeffs(num, den, ts):
    """Tustin of (n1 s + n0)/(d1 s + d0): y(k) = b0 u(k) + b1 u(k-1) - a1 y(k-1). Returns (b0, b1, a1)."""
    n1, n0 = (np.asarray(c, dtype=float) for c in num)
    d1, d0 = (np.asarray(c, dtype=float) for c in den)
    k = 2.0 / ts
    g = d1 * k + d0
    return (n1 * k + n0) / g, (n0 - n1 * k) / g, (d0 - d1 * k) / g


# --------------------------------------------------------------------------- base
def _arr(x, n, dtype):
    if type(x) is np.ndarray and x.dtype == dtype and x.shape == (n,):
        return x  # already in the working precision (the common case inside a step): no copy
    if np.ndim(x) == 0:
        return np.full(n, float(x), dtype=dtype)
    return np.ascontiguousarray(np.broadcast_to(np.asarray(x, dtype=float), (n,)).astype(dtype))


def select(mask, new, old):
    return new if mask is None else np.where(mask, new, old)


class Block:
    state_names: tuple[str, ...] = ()

    def __init__(self, n: int, ts: float, dtype=np.float64):
        self.n = int(n)
        self.ts = float(ts)
        self.dtype = np.dtype(dtype)
        self.s = {name: np.zeros(self.n, dtype=self.dtype) for name in self.state_names}
        self._ts = self.dtype.type(ts)

    def c(self, x):
        """Cast to the block's dtype (array of shape (N,))."""
        return _arr(x, self.n, self.dtype)

    def _commit(self, mask, **new):
        for k, v in new.items():
            self.s[k] = select(mask, np.asarray(v, dtype=self.dtype), self.s[k]).astype(self.dtype, copy=False)

    def snapshot(self, index: int) -> dict[str, float]:
        return {k: float(v[index]) for k, v in self.s.items()}

    def restore(self, index: int, state: dict[str, float]) -> None:
        for k in self.s:
            self.s[k] = self.s[k].copy()  # states may share memory with other arrays: never write in place
            self.s[k][index] = self.dtype.type(state[k])


# --------------------------------------------------------------------------- PI
class TustinPI(Block):
    """Tustin PI, recursive form (paper eq. 12 generic): y(k) = y(k-1) + b0 e(k) + b1 e(k-1)."""

    state_names = ("y1", "e1")

    def __init__(self, kp, ki, ts, n, dtype=np.float64):
        super().__init__(n, ts, dtype)
        self.kp = self.c(kp)
        b0, b1 = tustin_pi_coeffs(np.broadcast_to(kp, (n,)), np.broadcast_to(ki, (n,)), ts)
        self.b0, self.b1 = self.c(b0), self.c(b1)

    def step(self, e, mask=None, hold=None):
        """hold (bool array): integrator frozen (anti-windup), only the proportional part acts."""
        e = self.c(e)
        y = self.s["y1"] + self.b0 * e + self.b1 * self.s["e1"]
        if hold is not None:
            y = np.where(hold, self.s["y1"] + self.kp * (e - self.s["e1"]), y)
        self._commit(mask, y1=y, e1=e)
        return y

    def set_operating_point(self, mask, y, e):
        """Make the last output y at error e (next output continues from y)."""
        self._commit(mask, y1=self.c(y), e1=self.c(e))

    def change_prev_error(self, mask, e_old, e_new):
        """Bumpless change of the error definition: the last error is re-expressed with the new law."""
        self._commit(mask, e1=self.c(e_new))

    def shift(self, mask, dy):
        self._commit(mask, y1=self.s["y1"] + self.c(dy))


class CumulativePI(Block):
    """Trapezoidal-cumulative PI (paper eq. 13) with an explicit running sum.

    y(n) = K_p e(n) + i0 + K_i Ts [ (e(0) + e(n))/2 + sum_{k=1}^{n-1} e(k) ].
    ``s`` is the running sum, ``e0`` the first error, ``i0`` the integrator's initial value,
    ``started`` 0 before the first sample. ``i_last``/``e_last`` allow a bumpless rebase.
    """

    state_names = ("i0", "e0", "s", "started", "i_last", "e_last")

    def __init__(self, kp, ki, ts, n, dtype=np.float64):
        super().__init__(n, ts, dtype)
        self.kp, self.ki = self.c(kp), self.c(ki)
        self.s["started"][:] = 1  # zero history (e(-1) = 0), the same convention as TustinPI

    def step(self, e, mask=None, hold=None):
        """hold: integrator frozen; the sums restart at this sample (i0 = last integral, e0 = e)."""
        e = self.c(e)
        st = self.s["started"] > 0
        half = self.dtype.type(0.5)
        i_run = self.s["i0"] + self.ki * self._ts * ((self.s["e0"] + e) * half + self.s["s"])
        i_now = np.where(st, i_run, self.s["i0"])
        i0, e0, s = self.s["i0"], np.where(st, self.s["e0"], e), np.where(st, self.s["s"] + e, self.s["s"])
        if hold is not None:
            i_now = np.where(hold, self.s["i_last"], i_now)
            i0 = np.where(hold, i_now, i0)
            e0 = np.where(hold, e, e0)
            s = np.where(hold, self.dtype.type(0.0), s)
        y = self.kp * e + i_now
        # the running sum holds e(1..n-1): e(n) is added only after it served as the end point
        self._commit(mask, i0=i0, e0=e0, s=s, started=np.ones(self.n, self.dtype), i_last=i_now, e_last=e)
        return y

    def set_operating_point(self, mask, y, e):
        y, e = self.c(y), self.c(e)
        i = y - self.kp * e
        z = np.zeros(self.n, self.dtype)
        self._commit(mask, i0=i, e0=e, s=z, started=np.ones(self.n, self.dtype), i_last=i, e_last=e)

    def change_prev_error(self, mask, e_old, e_new):
        y_last = self.kp * self.s["e_last"] + self.s["i_last"]
        y_last = y_last - self.kp * (self.c(e_old) - self.s["e_last"])  # e_old == e_last normally
        self.set_operating_point(mask, y_last, e_new)

    def shift(self, mask, dy):
        dy = self.c(dy)
        self._commit(mask, i0=self.s["i0"] + dy, i_last=self.s["i_last"] + dy)


class EulerPI(Block):
    """Forward-Euler PI: y(k) = K_p e(k) + xi(k), xi(k+1) = xi(k) + Ts K_i e(k)."""

    state_names = ("xi",)

    def __init__(self, kp, ki, ts, n, dtype=np.float64):
        super().__init__(n, ts, dtype)
        self.kp, self.ki = self.c(kp), self.c(ki)

    def step(self, e, mask=None, hold=None):
        e = self.c(e)
        y = self.kp * e + self.s["xi"]
        xi = self.s["xi"] + self._ts * self.ki * e
        if hold is not None:
            xi = np.where(hold, self.s["xi"], xi)
        self._commit(mask, xi=xi)
        return y

    def set_operating_point(self, mask, y, e):
        self._commit(mask, xi=self.c(y) - self.kp * self.c(e))

    def change_prev_error(self, mask, e_old, e_new):
        self._commit(mask, xi=self.s["xi"] + self.kp * (self.c(e_old) - self.c(e_new)))

    def shift(self, mask, dy):
        self._commit(mask, xi=self.s["xi"] + self.c(dy))


def make_pi(method, kp, ki, ts, n, dtype=np.float64):
    return {"tustin": TustinPI, "trapezoid_cumulative": CumulativePI, "euler": EulerPI}[method](
        kp, ki, ts, n, dtype
    )


# --------------------------------------------------------------------------- first order
class TustinFirstOrder(Block):
    """Tustin of (n1 s + n0)/(d1 s + d0): y(k) = b0 u(k) + b1 u(k-1) - a1 y(k-1).

    Used for the voltage low-pass 1/(1 + sT), the friction input lag 1/(1+sT_LPF), the washouts
    K s/(1 + sT_v) and the lead-lags (1 + sT_1)/(1 + sT_2).
    """

    state_names = ("u1", "y1")

    def __init__(self, num, den, ts, n, dtype=np.float64):
        super().__init__(n, ts, dtype)
        b0, b1, a1 = tustin_first_order_coeffs(num, den, ts)
        self.b0, self.b1, self.a1 = self.c(b0), self.c(b1), self.c(a1)
        n0, d0 = float(num[1]), float(den[1])
        self.dc = n0 / d0

    def step(self, u, mask=None, hold=None):
        u = self.c(u)
        y = self.b0 * u + self.b1 * self.s["u1"] - self.a1 * self.s["y1"]
        u1 = u
        if hold is not None:  # freeze: keep the output; resume as if at rest at that output
            y = np.where(hold, self.s["y1"], y)
            u1 = np.where(hold, self.s["y1"] / self.dtype.type(self.dc), u)
        self._commit(mask, u1=u1, y1=y)
        return y

    def set_steady(self, mask, u):
        u = self.c(u)
        self._commit(mask, u1=u, y1=u * self.dtype.type(self.dc))


class EulerFirstOrder(Block):
    """Forward Euler of (n1 s + n0)/(d1 s + d0) in state-space form.

    x' = a x + u, y = cx x + dd u with a = -d0/d1, dd = n1/d1, cx = (n0 - dd d0)/d1.
    """

    state_names = ("x",)

    def __init__(self, num, den, ts, n, dtype=np.float64):
        super().__init__(n, ts, dtype)
        n1, n0 = (float(v) for v in num)
        d1, d0 = (float(v) for v in den)
        dd = n1 / d1
        self.a, self.cx, self.dd = self.c(-d0 / d1), self.c((n0 - dd * d0) / d1), self.c(dd)
        self.dc = n0 / d0

    def step(self, u, mask=None, hold=None):
        u = self.c(u)
        x = self.s["x"]
        y = self.cx * x + self.dd * u
        xn = x + self._ts * (self.a * x + u)
        if hold is not None:
            xn = np.where(hold, x, xn)
        self._commit(mask, x=xn)
        return y

    def set_steady(self, mask, u):
        u = self.c(u)
        self._commit(mask, x=-u / self.a)


def make_first_order(method, num, den, ts, n, dtype=np.float64):
    cls = EulerFirstOrder if method == "euler" else TustinFirstOrder
    return cls(num, den, ts, n, dtype)
