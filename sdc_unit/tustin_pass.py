"""One Tustin sample of :class:`sdc_unit.discrete.DiscreteVisc`, written out for speed.

The generic pass (``DiscreteVisc._pass``) calls one block object per transfer function; each call
casts its input and commits its states with a masked select. That costs several hundred numpy
calls per sample, which, not the arithmetic, is what limits an SDC serving 50 turbines at
Ts = 0.67 ms. This pass evaluates the same recursions (the formulas of
:class:`sdc_unit.blocks.TustinFirstOrder`, :class:`~sdc_unit.blocks.TustinPI` and
:class:`~sdc_unit.blocks.TustinSwing`, operand for operand and in the same order, so float64 and
float32 results are bit-identical to the generic pass; a unit test holds it to that) on the
blocks' own state and coefficient arrays, and returns the new states instead of committing them:
the caller commits once, after it knows whether the limiter prediction holds.
"""

from __future__ import annotations

import math

import numpy as np

from . import law


def _first_order(b, u, hold, new):
    """TustinFirstOrder.step without the commit: y = b0 u + b1 u(k-1) - a1 y(k-1)."""
    s = b.s
    y = b.b0 * u + b.b1 * s["u1"] - b.a1 * s["y1"]
    u1 = u
    if hold is not None:
        y = np.where(hold, s["y1"], y)
        u1 = np.where(hold, s["y1"] / b.dtype.type(b.dc), u)
    new.append((b, "u1", u1))
    new.append((b, "y1", y))
    return y


def _pi(b, e, hold, new):
    """TustinPI.step without the commit: y = y(k-1) + b0 e + b1 e(k-1); integrator frozen on hold."""
    s = b.s
    y = s["y1"] + b.b0 * e + b.b1 * s["e1"]
    if hold is not None:
        y = np.where(hold, s["y1"] + b.kp * (e - s["e1"]), y)
    new.append((b, "y1", y))
    new.append((b, "e1", e))
    return y


def _swing(b, t, w, new):
    """TustinSwing.step without the commit: the delta recursion and the backward-difference speed."""
    s = b.s
    dt = b.dtype.type
    d1 = s["d1"]
    dl = (
        b.a1 * d1
        - b.a2 * s["d2"]
        + b.bt * (t + dt(2.0) * s["t1"] + s["t2"])
        + b.bw0 * w
        + b.bw1 * s["w1"]
        + b.bw2 * s["w2"]
    )
    dev = (dl - d1) / dt(b.scale * b.ts)
    d_prev = d1
    if b.wrap:
        tp = dt(2.0 * math.pi)
        m = np.round(dl / tp)
        dl = dl - m * tp
        d_prev = d_prev - m * tp
    new += [(b, "d1", dl), (b, "d2", d_prev), (b, "t1", t), (b, "t2", s["t1"]), (b, "w1", w), (b, "w2", s["w1"])]
    return dl, dev


def tustin_pass(v, m: dict, lim_pred):
    """One sample of DiscreteVisc ``v`` (method "tustin") with the limiter state ``lim_pred``.

    Returns (new block states as (block, name, array) triples, new memory, outputs, limited);
    nothing is committed.
    """
    p, dt = v.p, v.dtype
    one = dt.type(1.0)
    new: list = []
    lim_prev, ild_pred, ilq_pred = lim_pred
    hold = lim_prev if p.freeze_vf_when_limited else None
    vfd = _first_order(v.lpf_d, m["v_d"], hold, new)
    vfq = _first_order(v.lpf_q, m["v_q"], hold, new)
    om_s = np.where(p.omega_s_measured, m["omega_meas"], one).astype(dt)
    # swing
    p_lim = m["v_d"] * ild_pred + m["v_q"] * ilq_pred
    p_e = np.where(lim_prev, p_lim, m["p"])
    t_err = dt.type(p.p_ref) - p_e
    delta, dev = _swing(v.swing, t_err, om_s - one, new)
    omega = one + dev
    # virtual friction, input omega_s - omega
    a = _first_order(v.f_lpf, om_s - omega, None, new)
    y = _first_order(v.f_w1, a, None, new) + _first_order(v.f_w2, a, None, new)
    vfr = _first_order(v.f_ll2, _first_order(v.f_ll1, y, None, new), None, new)
    rp = v.rp
    vfr_app = np.where(rp["supp"] > 0.5, vfr, dt.type(0.0))
    # AVR
    vmag = np.hypot(vfd, vfq)
    e = (rp["v_ref"].astype(dt) - vmag) + rp["m_q"].astype(dt) * (rp["q_ref"].astype(dt) - m["q"])
    u = _pi(v.avr, e, lim_prev if p.avr_antiwindup else None, new)
    e_mag = u + dt.type(p.e_ref) + vfr_app
    # quasi-stationary model and limiter
    isd, isq = law.qsem_current(e_mag, delta, vfd, vfq, omega, v.dtype_params)
    ild, ilq, limited = law.circular_limit(isd, isq, dt.type(p.i_max))
    # inner current loop
    lf = dt.type(p.l_f)
    ffd, ffq = (vfd, vfq) if p.ff_filtered else (m["v_d"], m["v_q"])
    v_ref_d = ffd - lf * m["i_q"] + _pi(v.pi_d, ild - m["i_d"], None, new)
    v_ref_q = ffq + lf * m["i_d"] + _pi(v.pi_q, ilq - m["i_q"], None, new)
    new_mem = dict(limited=limited.astype(dt), ild=ild, ilq=ilq, vmag=vmag, q=m["q"], vfr=vfr)
    out = dict(v_ref_d=v_ref_d, v_ref_q=v_ref_q, i_ref_d=ild, i_ref_q=ilq, delta=delta, omega=omega,
               e_mag=e_mag, v_f=vfr_app, p_e=p_e)
    return new, new_mem, out, limited
