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
are generic.
"""

from __future__ import annotations

import math

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


def tustin_swing_coeffs(h, d, ts):
    """Tustin of eq. (1): Theta = T/(2Hs^2 + Ds) + W/s, over the common denominator.

    delta(k) = a1 delta(k-1) - a2 delta(k-2) + bt [T(k) + 2T(k-1) + T(k-2)]
               + bw0 W(k) + bw1 W(k-1) + bw2 W(k-2)

    with K = 2/Ts, c0 = 2HK^2 + DK, c1 = DK - 2HK^2:
    a1 = 4HK^2/c0, a2 = (2HK^2 - DK)/c0, bt = 1/c0 (paper eq. 15, correct), and the EXACT Tustin
    term of W/s, (1 + z^-1)(c0 + c1 z^-1)/(K c0) (ERRATA item 2), i.e. bw = (c0, c0 + c1, c1)/(K c0);
    the paper prints (1 - z^-2)/K, exact only for D = 0.
    Returns dict(a1, a2, bt, bw0, bw1, bw2).
    """
    h = np.asarray(h, dtype=float)
    d = np.asarray(d, dtype=float)
    k = 2.0 / ts
    c0 = 2.0 * h * k * k + d * k
    c1 = d * k - 2.0 * h * k * k
    return dict(
        a1=4.0 * h * k * k / c0,
        a2=(2.0 * h * k * k - d * k) / c0,
        bt=1.0 / c0,
        bw0=c0 / (k * c0),
        bw1=(c0 + c1) / (k * c0),
        bw2=c1 / (k * c0),
    )


# --------------------------------------------------------------------------- base
def _arr(x, n, dtype):
    if type(x) is np.ndarray and x.dtype == dtype and x.shape == (n,):
        return x  # already in the working precision (the common case inside a step): no copy
    if np.ndim(x) == 0:
        return np.full(n, float(x), dtype=dtype)
    return np.ascontiguousarray(np.broadcast_to(np.asarray(x, dtype=float), (n,)).astype(dtype))


def _sel(mask, new, old):
    return new if mask is None else np.where(mask, new, old)


class _Block:
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
            self.s[k] = _sel(mask, np.asarray(v, dtype=self.dtype), self.s[k]).astype(self.dtype, copy=False)

    def snapshot(self, index: int) -> dict[str, float]:
        return {k: float(v[index]) for k, v in self.s.items()}

    def restore(self, index: int, state: dict[str, float]) -> None:
        for k in self.s:
            self.s[k] = self.s[k].copy()  # states may share memory with other arrays: never write in place
            self.s[k][index] = self.dtype.type(state[k])


# --------------------------------------------------------------------------- PI
class TustinPI(_Block):
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


class CumulativePI(_Block):
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


class EulerPI(_Block):
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
class TustinFirstOrder(_Block):
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


class EulerFirstOrder(_Block):
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


# --------------------------------------------------------------------------- swing (eq. 1)
class TustinSwing(_Block):
    """delta recursion of eq. (15) with the exact Tustin W/s term (ERRATA 2).

    ``scale`` multiplies the output (omega0 gives radians from the per-unit eq. 1). ``wrap`` keeps
    delta in (-pi, pi] by shifting delta(k) and delta(k-1) by the same multiple of 2 pi (exact,
    because a1 - a2 = 1). ``step`` returns (delta(k), backward-difference speed deviation
    [delta(k) - delta(k-1)]/(scale Ts) = omega - 1 in p.u.) -- a backward difference, not the
    Tustin inverse of the integrator (ERRATA 3).
    """

    state_names = ("d1", "d2", "t1", "t2", "w1", "w2")

    def __init__(self, h, d, ts, n, dtype=np.float64, scale=1.0, wrap=False):
        super().__init__(n, ts, dtype)
        self.scale = float(scale)
        self.wrap = bool(wrap)
        self.set_hd(None, h, d)

    def set_hd(self, mask, h, d, rebase=True):
        h = np.broadcast_to(np.asarray(h, dtype=float), (self.n,))
        d = np.broadcast_to(np.asarray(d, dtype=float), (self.n,))
        cf = tustin_swing_coeffs(h, d, self.ts)
        new = {k: self.c(v * (self.scale if k.startswith("b") else 1.0)) for k, v in cf.items()}
        # keep the integrator pole exactly at z = 1 in the working precision: a1 lies in (1, 2), so
        # a1 - 1 is exact (Sterbenz) and a1 - a2 == 1 holds in float32 too (rounding a1 and a2
        # separately left a pole at 1 + 1.6e-5 at Ts = 0.25 ms: a slow exponential drift of delta)
        new["a2"] = (new["a1"] - self.dtype.type(1.0)).astype(self.dtype)
        if mask is None or not hasattr(self, "a1"):
            for k, v in new.items():
                setattr(self, k, v)
        else:
            for k, v in new.items():
                setattr(self, k, np.where(mask, v, getattr(self, k)).astype(self.dtype))

    def step(self, t, w, mask=None):
        t, w = self.c(t), self.c(w)
        s = self.s
        two = self.dtype.type(2.0)
        dl = (
            self.a1 * s["d1"]
            - self.a2 * s["d2"]
            + self.bt * (t + two * s["t1"] + s["t2"])
            + self.bw0 * w
            + self.bw1 * s["w1"]
            + self.bw2 * s["w2"]
        )
        dev = (dl - s["d1"]) / self.dtype.type(self.scale * self.ts)
        d_prev = s["d1"]
        if self.wrap:
            tp = self.dtype.type(2.0 * math.pi)
            m = np.round(dl / tp)
            dl = dl - m * tp
            d_prev = d_prev - m * tp
        self._commit(mask, d1=dl, d2=d_prev, t1=t, t2=s["t1"], w1=w, w2=s["w1"])
        return dl, dev

    def set_operating_point(self, mask, delta, dw, t, w):
        delta, dw, t, w = self.c(delta), self.c(dw), self.c(t), self.c(w)
        d2 = delta - self.dtype.type(self.scale * self.ts) * (dw + w)
        self._commit(mask, d1=delta, d2=d2, t1=t, t2=t, w1=w, w2=w)


class CumulativeSwing(_Block):
    """Eq. (1) by the trapezoidal rule with explicit running sums (the 'trapezoidal-cumulative' SDC).

    dw(n) = dw0 + c [ (f0 + f(n))/2 + sum_{1}^{n-1} f ], f = T - D dw, c = Ts/(2H)  (solved for dw(n));
    delta(n) = dl0 + scale Ts [ (g0 + g(n))/2 + sum_{1}^{n-1} g ], g = dw + W.
    """

    state_names = ("dw0", "f0", "sf", "dl0", "g0", "sg", "started", "dw_last", "dl_last", "t_last", "w_last")

    def __init__(self, h, d, ts, n, dtype=np.float64, scale=1.0, wrap=False):
        super().__init__(n, ts, dtype)
        self.scale = float(scale)
        self.h = self.c(h)
        self.d = self.c(d)
        self.s["started"][:] = 1  # zero history, the same convention as TustinSwing

    def set_hd(self, mask, h, d, rebase=True):
        if rebase:  # restart the sums at the last sample with the new law (otherwise the whole history is re-weighted)
            s = self.s
            f0 = s["t_last"] - self.c(d) * s["dw_last"]
            g0 = s["dw_last"] + s["w_last"]
            z = np.zeros(self.n, self.dtype)
            self._commit(mask, dw0=s["dw_last"], f0=f0, sf=z, dl0=s["dl_last"], g0=g0, sg=z)
        self.h = _sel(mask, self.c(h), self.h).astype(self.dtype)
        self.d = _sel(mask, self.c(d), self.d).astype(self.dtype)

    def step(self, t, w, mask=None):
        t, w = self.c(t), self.c(w)
        s = self.s
        half = self.dtype.type(0.5)
        one = self.dtype.type(1.0)
        st = s["started"] > 0
        cc = self._ts / (self.dtype.type(2.0) * self.h)
        dw_run = (s["dw0"] + cc * (s["f0"] * half + s["sf"] + t * half)) / (one + cc * self.d * half)
        dw = np.where(st, dw_run, s["dw0"])
        f = t - self.d * dw
        g = dw + w
        sc = self.dtype.type(self.scale) * self._ts
        dl_run = s["dl0"] + sc * ((s["g0"] + g) * half + s["sg"])
        dl = np.where(st, dl_run, s["dl0"])
        dev = (dl - s["dl_last"]) / self.dtype.type(self.scale * self.ts)
        self._commit(
            mask,
            f0=np.where(st, s["f0"], f),
            g0=np.where(st, s["g0"], g),
            sf=np.where(st, s["sf"] + f, s["sf"]),
            sg=np.where(st, s["sg"] + g, s["sg"]),
            started=np.ones(self.n, self.dtype),
            dw_last=dw,
            dl_last=dl,
            t_last=t,
            w_last=w,
        )
        return dl, dev

    def set_operating_point(self, mask, delta, dw, t, w):
        delta, dw, t, w = self.c(delta), self.c(dw), self.c(t), self.c(w)
        z = np.zeros(self.n, self.dtype)
        self._commit(
            mask,
            dw0=dw,
            f0=t - self.d * dw,
            sf=z,
            dl0=delta,
            g0=dw + w,
            sg=z,
            started=np.ones(self.n, self.dtype),
            dw_last=dw,
            dl_last=delta,
            t_last=t,
            w_last=w,
        )


class EulerSwing(_Block):
    """Forward Euler of eq. (1): delta(k+1) = delta(k) + scale Ts (dw(k) + W(k)),
    dw(k+1) = dw(k) + Ts/(2H) (T(k) - D dw(k)); output delta(k)."""

    state_names = ("dw", "dl", "dl_last")

    def __init__(self, h, d, ts, n, dtype=np.float64, scale=1.0, wrap=False):
        super().__init__(n, ts, dtype)
        self.scale = float(scale)
        self.h = self.c(h)
        self.d = self.c(d)

    def set_hd(self, mask, h, d, rebase=True):
        self.h = _sel(mask, self.c(h), self.h).astype(self.dtype)
        self.d = _sel(mask, self.c(d), self.d).astype(self.dtype)

    def step(self, t, w, mask=None):
        t, w = self.c(t), self.c(w)
        s = self.s
        dl, dw = s["dl"], s["dw"]
        dev = (dl - s["dl_last"]) / self.dtype.type(self.scale * self.ts)
        dwn = dw + self._ts / (self.dtype.type(2.0) * self.h) * (t - self.d * dw)
        dln = dl + self.dtype.type(self.scale) * self._ts * (dw + w)
        self._commit(mask, dw=dwn, dl=dln, dl_last=dl)
        return dl, dev

    def set_operating_point(self, mask, delta, dw, t, w):
        delta, dw, w = self.c(delta), self.c(dw), self.c(w)
        self._commit(mask, dw=dw, dl=delta, dl_last=delta - self.dtype.type(self.scale) * self._ts * (dw + w))


def make_swing(method, h, d, ts, n, dtype=np.float64, scale=1.0, wrap=False):
    cls = {"tustin": TustinSwing, "trapezoid_cumulative": CumulativeSwing, "euler": EulerSwing}[method]
    return cls(h, d, ts, n, dtype, scale=scale, wrap=wrap)
