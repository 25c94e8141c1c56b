"""The swing equation (paper eq. 1) discretised, vectorised over N instances: the delta recursion of
eq. (15) (Tustin), the trapezoidal-cumulative form of eq. (13) and forward Euler -- the three
methods of :mod:`sdc_unit.blocks`, with the same conventions (``dtype``, ``mask``, states in ``s``).
"""

from __future__ import annotations

import math

import numpy as np

from .blocks import Block, select


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


class TustinSwing(Block):
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


class CumulativeSwing(Block):
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
        self.h = select(mask, self.c(h), self.h).astype(self.dtype)
        self.d = select(mask, self.c(d), self.d).astype(self.dtype)

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


class EulerSwing(Block):
    """Forward Euler of eq. (1): delta(k+1) = delta(k) + scale Ts (dw(k) + W(k)),
    dw(k+1) = dw(k) + Ts/(2H) (T(k) - D dw(k)); output delta(k)."""

    state_names = ("dw", "dl", "dl_last")

    def __init__(self, h, d, ts, n, dtype=np.float64, scale=1.0, wrap=False):
        super().__init__(n, ts, dtype)
        self.scale = float(scale)
        self.h = self.c(h)
        self.d = self.c(d)

    def set_hd(self, mask, h, d, rebase=True):
        self.h = select(mask, self.c(h), self.h).astype(self.dtype)
        self.d = select(mask, self.c(d), self.d).astype(self.dtype)

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
