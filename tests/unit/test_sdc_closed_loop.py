"""Closed loop: DiscreteVisc (Tustin, Ts = 0.67 ms, ZOH + one-sample delay) vs the continuous law.

Tiny test plant: converter filter (l_f/omega0) di/dt = v_conv - v - (r_f + j l_f) i, terminal voltage
v = v_g + z_g i (quasi-stationary grid impedance), ideal source v_g. The continuous reference is
law.derivatives + the same plant integrated by solve_ivp.
"""

import functools

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from sdc_unit import law
from sdc_unit.discrete import DiscreteVisc
from sdc_unit.law import Measurements
from sdc_unit.params import ViscParams

P = ViscParams()
ZG = 0.005 + 0.1j
W0 = P.omega0
T_END = 2.0
T_STEP = 0.2


def vg_of(t, case):
    return 0.3 if (case == "dip" and 1.0 <= t < 1.3) else 1.0


def vstar(t, case):
    return 1.04 if (case == "vstep" and t >= T_STEP) else 1.0


def meas_of(i, t, case):
    return Measurements.from_complex(np.atleast_1d(vg_of(t, case) + ZG * i), np.atleast_1d(i))


def plant_di(i, vconv, t, case):
    v = vg_of(t, case) + ZG * i
    return (vconv - v - (P.r_f + 1j * P.l_f) * i) * W0 / P.l_f


@functools.cache
def continuous(case):
    """The continuous law + plant by solve_ivp, on a 0.1 ms grid; computed once per case (shared by the tests).

    Integrated piece by piece between the source/reference steps (T_STEP; 1.0 and 1.3 s), so that no
    step straddles a discontinuity, with RK45's own step size (rtol 1e-6). Against the same
    integration at rtol 1e-10 its largest error is 8e-6 of each signal's range (measured, both cases),
    over a thousand times below the 1 % the tests assert; the former max_step = 1e-4 run, which
    straddled the steps, was off by up to 1.9e-4 and took ~50 times as long."""
    params = {v: P.with_changes(v_ref=v) for v in (1.0, 1.04)}  # the two values vstar takes

    def f(t, y):
        i = y[0] + 1j * y[1]
        x = y[2:].reshape(law.NX, 1)
        dx, o = law.evaluate(x, meas_of(i, t, case), params[vstar(t, case)])  # derivatives and outputs, one call
        di = plant_di(i, o.v_ref_d[0] + 1j * o.v_ref_q[0], t, case)
        return np.concatenate([[di.real, di.imag], dx.ravel()])

    x0 = law.initial_state(meas_of(0j, 0.0, case), P)
    y = np.concatenate([[0.0, 0.0], x0.ravel()])
    tev = np.arange(0.0, T_END, 1e-4)
    edges = [0.0, *((T_STEP,) if case == "vstep" else (1.0, 1.3)), T_END]
    ts, ys = [], []
    for a, b in zip(edges[:-1], edges[1:]):
        te = tev[(tev >= a) & (tev < b)]
        sol = solve_ivp(f, (a, b), y, method="RK45", t_eval=np.append(te, b), rtol=1e-6, atol=1e-8)
        assert sol.status == 0
        ts.append(sol.t[:-1])
        ys.append(sol.y[:, :-1])
        y = sol.y[:, -1]  # the state at b starts the next piece
    t, y = np.concatenate(ts), np.hstack(ys)
    i = y[0] + 1j * y[1]
    v = np.array([vg_of(tk, case) for tk in t]) + ZG * i
    pv = P.with_changes(v_ref=np.array([vstar(tk, case) for tk in t]))  # the law on all samples at once
    e = law.outputs(y[2:], Measurements.from_complex(v, i), pv).e_mag
    return t, dict(v=np.abs(v), q=(v * np.conj(i)).imag, delta=y[2], e=e)


def discrete(case, ts=0.67e-3, delay=1):
    c = DiscreteVisc(1, P, ts=ts)
    i = 0j
    c.initialise(0, meas_of(i, 0.0, case))
    queue = [c.last["v_ref_d"][0] + 1j * c.last["v_ref_q"][0]] * (delay + 1)
    rec = {k: [] for k in ("t", "v", "q", "delta", "e")}
    changed = False
    nsub = 8
    for k in range(int(np.ceil(T_END / ts))):
        t = k * ts
        if case == "vstep" and t >= T_STEP and not changed:
            c.set_params(0, bumpless=False, v_ref=1.04)  # a reference step, as in the continuous law
            changed = True
        m = meas_of(i, t, case)
        o = c.step(m)
        queue.append(o.v_ref_d[0] + 1j * o.v_ref_q[0])
        vconv = queue[-1 - delay]  # zero-order hold, applied `delay` samples later
        h = ts / nsub
        for j in range(nsub):
            tt = t + j * h
            k1 = plant_di(i, vconv, tt, case)
            k2 = plant_di(i + h / 2 * k1, vconv, tt + h / 2, case)
            k3 = plant_di(i + h / 2 * k2, vconv, tt + h / 2, case)
            k4 = plant_di(i + h * k3, vconv, tt + h, case)
            i = i + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        rec["t"].append(t)
        rec["v"].append(np.hypot(m.v_d[0], m.v_q[0]))
        rec["q"].append(m.q[0])
        rec["delta"].append(o.delta[0])
        rec["e"].append(o.e_mag[0])
    return {k: np.array(v) for k, v in rec.items()}


def rel_rms(case, ts=0.67e-3, delay=1, exclude=()):
    tc, ref = continuous(case)
    d = discrete(case, ts, delay)
    keep = np.ones(d["t"].shape, bool)
    for a, b in exclude:
        keep &= ~((d["t"] >= a) & (d["t"] < b))
    out = {}
    for name in ("v", "q", "delta", "e"):
        r = np.interp(d["t"], tc, ref[name])
        out[name] = np.sqrt(np.mean((d[name] - r)[keep] ** 2)) / (ref[name].max() - ref[name].min())
    print(case, ts, delay, exclude, {k: f"{v:.4f}" for k, v in out.items()})
    return out


@pytest.mark.slow
def test_vstep_tracks_continuous_reference():
    r = rel_rms("vstep")
    assert r["v"] < 0.01 and r["q"] < 0.01 and r["e"] < 0.01
    # delta moves only 1.7e-3 rad on a stiff bus; its RMS error (4.9e-5 rad) is 2.9 % of that range
    # at Ts = 0.67 ms -- the 1 % target is NOT met for delta here (see docs/sdc.md); bound as measured:
    assert r["delta"] < 0.04


@pytest.mark.slow
def test_vstep_delta_converges_with_ts():
    assert rel_rms("vstep", ts=0.2e-3)["delta"] < 0.01


@pytest.mark.slow
def test_dip_tracks_continuous_reference():
    r = rel_rms("dip")
    assert r["v"] < 0.01 and r["e"] < 0.01
    # Q: the sampled loop reacts one sample + one delay late to the source steps at 1.0 and 1.3 s;
    # the Q spikes in those 20 ms dominate (4.5 % overall, measured); elsewhere Q tracks within 1 %.
    assert r["q"] < 0.06
    assert rel_rms("dip", exclude=((1.0, 1.02), (1.3, 1.32)))["q"] < 0.01
    # delta (range 0.012 rad) inherits the integral of those P spikes: ~30 % at 0.67 ms (measured)
    assert r["delta"] < 0.35


@pytest.mark.slow
def test_dip_delta_converges_with_ts():
    assert rel_rms("dip", ts=0.2e-3, delay=0)["delta"] < 0.01


@pytest.mark.parametrize("kpc", [1.27])
def test_dartco_current_gains_unstable_at_067ms(kpc):
    """Discrete current loop with one-sample delay: plant i(k+1) = a i(k) + b v(k-1) (scalar, d-axis
    after decoupling); D'Arco's k_pc = 1.27 gives a pole outside the unit circle, 0.13 does not."""
    ts = 0.67e-3
    a = np.exp(-W0 * P.r_f / P.l_f * ts)
    b = (1 - a) / P.r_f

    def rho(kp, ki):
        # states: i(k), v(k-1), integrator s(k);  v(k) = kp e + s, s(k+1) = s + ki ts e, e = -i
        m = np.array([[a, b, 0.0], [-kp, 0.0, 1.0], [-ki * ts, 0.0, 1.0]])
        return max(abs(np.linalg.eigvals(m)))

    assert rho(kpc, 14.3) > 1.0
    assert rho(P.k_pc, P.k_ic) < 1.0  # slowest pole 0.992 = the cancelled filter pole at 11.8 rad/s
