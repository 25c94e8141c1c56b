"""Figures of docs/sdc.md: the discretised SDViSC against the continuous ("hardware-dependent") ViSC.

    .venv/bin/python benchmarks/sdc_figures.py        # ~2-3 min; PNGs into docs/figures/, JSON to stdout

Plant: the small test plant of ``tests/unit/test_sdc_closed_loop.py`` (copied below): one turbine's
converter filter (l_f/omega0) di/dt = v_conv - v - (r_f + j l_f) i, terminal voltage v = v_g + z_g i
(quasi-stationary grid impedance z_g = 0.005 + j0.1 p.u.), ideal source v_g. A phase-to-ground-fault-like
disturbance is represented, in this positive-sequence RMS model, by a balanced dip of v_g to 0.3 p.u.
at 1.0 s, cleared at 1.3 s (the paper's fault timing; no sub-cycle or negative-sequence effects).
The discrete controller is sampled every Ts and its output applied through a zero-order hold one
sample later (one-sample transport delay). The continuous reference is ``law.derivatives`` plus the
same plant integrated by ``solve_ivp`` (RK45, max step 0.1 ms).

Figures (docs/figures/):

* ``sdc_tustin_vs_continuous.png``: Tustin at Ts = 0.67 ms vs continuous, |v|, Q, delta, E.
* ``sdc_cumulative_vs_tustin.png``: trapezoidal-cumulative vs Tustin at Ts = 0.25 ms over 10 s with the
  same dip, float64 and float32 (each controller in its own closed loop); |difference| vs time, log scale,
  of the AVR PI output u = E - E* - V_F and of delta.
* ``sdc_euler_vs_tustin.png``: forward Euler vs Tustin at Ts = 0.67 ms on the same dip, with the continuous
  reference.

RMS numbers: relative = RMS(discrete - continuous) / (max - min of the continuous trace) over the
whole run, as in the closed-loop tests; absolute RMS in p.u. (rad for delta) is given too.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from sdc_unit import law  # noqa: E402
from sdc_unit.discrete import DiscreteVisc  # noqa: E402
from sdc_unit.law import Measurements  # noqa: E402
from sdc_unit.params import ViscParams  # noqa: E402

FIG_DIR = ROOT / "docs" / "figures"
P = ViscParams()
ZG = 0.005 + 0.1j
W0 = P.omega0
T_DIP, T_CLEAR, V_DIP = 1.0, 1.3, 0.3
NAMES = ("v", "q", "delta", "e")
LABELS = {"v": "|v| [p.u.]", "q": "Q [p.u.]", "delta": "δ [rad]", "e": "E [p.u.]"}


# --------------------------------------------------------------------------- test plant (copied)
def vg_of(t):
    return V_DIP if T_DIP <= t < T_CLEAR else 1.0


def meas_of(i, t):
    return Measurements.from_complex(np.atleast_1d(vg_of(t) + ZG * i), np.atleast_1d(i))


def plant_di(i, vconv, t):
    v = vg_of(t) + ZG * i
    return (vconv - v - (P.r_f + 1j * P.l_f) * i) * W0 / P.l_f


def continuous(t_end):
    """The continuous ViSC law + plant by solve_ivp, sampled every 0.1 ms."""

    def f(t, y):
        i = y[0] + 1j * y[1]
        x = y[2:].reshape(law.NX, 1)
        m = meas_of(i, t)
        o = law.outputs(x, m, P)
        di = plant_di(i, o.v_ref_d[0] + 1j * o.v_ref_q[0], t)
        return np.concatenate([[di.real, di.imag], law.derivatives(x, m, P).ravel()])

    x0 = law.initial_state(meas_of(0j, 0.0), P)
    y0 = np.concatenate([[0.0, 0.0], x0.ravel()])
    tev = np.arange(0.0, t_end, 1e-4)
    sol = solve_ivp(f, (0, t_end), y0, method="RK45", t_eval=tev, max_step=1e-4, rtol=1e-6, atol=1e-8)
    if sol.status != 0:
        raise RuntimeError(sol.message)
    i = sol.y[0] + 1j * sol.y[1]
    v = np.array([vg_of(t) for t in sol.t]) + ZG * i
    e = np.array([law.outputs(sol.y[2:, k : k + 1], meas_of(i[k], sol.t[k]), P).e_mag[0] for k in range(len(sol.t))])
    return sol.t, dict(v=np.abs(v), q=(v * np.conj(i)).imag, delta=sol.y[2], e=e)


def discrete(configs, ts, t_end, delay=1, nsub=8):
    """Closed loops of several DiscreteVisc configurations [(method, dtype), ...], each with its own
    copy of the plant (vectorised over the configurations). Returns one record per configuration."""
    nc = len(configs)
    ctrls = [DiscreteVisc(1, P, ts=ts, method=m, dtype=d) for m, d in configs]
    i = np.zeros(nc, complex)
    for c in ctrls:
        c.initialise(0, meas_of(0j, 0.0))
    v0 = np.array([c.last["v_ref_d"][0] + 1j * c.last["v_ref_q"][0] for c in ctrls])
    queue = [v0] * (delay + 1)
    n_steps = int(np.ceil(t_end / ts))
    rec = {k: np.empty((nc, n_steps)) for k in ("v", "q", "delta", "e", "u")}
    t_axis = np.arange(n_steps) * ts
    h = ts / nsub
    for k in range(n_steps):
        t = k * ts
        vout = np.empty(nc, complex)
        for j, c in enumerate(ctrls):
            m = meas_of(i[j], t)
            o = c.step(m)
            vout[j] = o.v_ref_d[0] + 1j * o.v_ref_q[0]
            rec["v"][j, k] = np.hypot(m.v_d[0], m.v_q[0])
            rec["q"][j, k] = m.q[0]
            rec["delta"][j, k] = o.delta[0]
            rec["e"][j, k] = o.e_mag[0]
            rec["u"][j, k] = o.e_mag[0] - P.e_ref - o.v_f[0]  # AVR PI output (V_F = 0 with supp off)
        queue.append(vout)
        queue.pop(0)
        vconv = queue[-1 - delay]
        for jj in range(nsub):  # RK4 of the plant over one sample, v_conv held
            tt = t + jj * h
            k1 = plant_di(i, vconv, tt)
            k2 = plant_di(i + h / 2 * k1, vconv, tt + h / 2)
            k3 = plant_di(i + h / 2 * k2, vconv, tt + h / 2)
            k4 = plant_di(i + h * k3, vconv, tt + h)
            i = i + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return t_axis, [{k: v[j] for k, v in rec.items()} for j in range(nc)]


def rms_vs_ref(t, d, tc, ref):
    out = {}
    for name in NAMES:
        r = np.interp(t, tc, ref[name])
        err = d[name] - r
        if not np.all(np.isfinite(err)):
            out[name] = {"rms_abs": float("nan"), "rms_rel": float("nan"), "finite": False}
            continue
        rms = float(np.sqrt(np.mean(err**2)))
        out[name] = {"rms_abs": rms, "rms_rel": rms / float(ref[name].max() - ref[name].min())}
    return out


def _shade(ax):
    ax.axvspan(T_DIP, T_CLEAR, color="0.9", zorder=0)


# --------------------------------------------------------------------------- figures
def fig_tustin_vs_continuous(tc, ref, t, tus):
    fig, axes = plt.subplots(4, 1, figsize=(7.5, 8.5), sharex=True)
    for ax, name in zip(axes, NAMES):
        _shade(ax)
        ax.plot(tc, ref[name], "k-", lw=1.4, label="continuous ViSC (solve_ivp)")
        ax.plot(t, tus[name], "C1--", lw=1.2, label="SDViSC, Tustin, Ts = 0.67 ms")
        ax.set_ylabel(LABELS[name])
        ax.grid(alpha=0.3)
    axes[0].legend(loc="lower right", fontsize=8)
    axes[0].set_title("Source dip to 0.3 p.u. 1.0-1.3 s (positive-sequence RMS model), z_g = 0.005 + j0.1 p.u.",
                      fontsize=9)
    axes[-1].set_xlabel("t [s]")
    fig.tight_layout()
    path = FIG_DIR / "sdc_tustin_vs_continuous.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path.name


def fig_euler_vs_tustin(tc, ref, t, tus, eul):
    fig, axes = plt.subplots(4, 1, figsize=(7.5, 8.5), sharex=True)
    for ax, name in zip(axes, NAMES):
        _shade(ax)
        ax.plot(tc, ref[name], "k-", lw=1.4, label="continuous ViSC")
        ax.plot(t, tus[name], "C1--", lw=1.2, label="Tustin, Ts = 0.67 ms")
        ax.plot(t, eul[name], "C0:", lw=1.4, label="forward Euler, Ts = 0.67 ms")
        ax.set_ylabel(LABELS[name])
        ax.grid(alpha=0.3)
        lo, hi = float(ref[name].min()), float(ref[name].max())
        pad = 0.6 * (hi - lo) + 1e-3
        if not np.all(np.isfinite(eul[name])) or np.nanmax(np.abs(eul[name] - np.interp(t, tc, ref[name]))) > 3 * (hi - lo):
            ax.set_ylim(lo - pad, hi + pad)  # keep the reference readable if Euler runs away
    axes[0].legend(loc="lower right", fontsize=8)
    axes[0].set_title("Euler vs Tustin at Ts = 0.67 ms, source dip 1.0-1.3 s", fontsize=9)
    axes[-1].set_xlabel("t [s]")
    fig.tight_layout()
    path = FIG_DIR / "sdc_euler_vs_tustin.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path.name


def _absdiff(a, b, angle=False):
    d = np.angle(np.exp(1j * (a - b))) if angle else a - b
    return np.abs(d)


def fig_cumulative_vs_tustin(t, runs):
    tus64, cum64, tus32, cum32 = runs
    floor = 1e-18
    fig, axes = plt.subplots(2, 1, figsize=(7.5, 6.5), sharex=True)
    stats = {}
    for ax, (name, angle, lab) in zip(axes, (("u", False, "AVR PI output u [p.u.]"), ("delta", True, "δ [rad]"))):
        _shade(ax)
        pairs = {
            "cumulative64 - tustin64": (cum64, tus64, "C3", "-"),
            "cumulative32 - tustin32": (cum32, tus32, "C0", "-"),
            "tustin32 - tustin64": (tus32, tus64, "C2", ":"),
            "cumulative32 - tustin64": (cum32, tus64, "C4", ":"),
        }
        for lab_pair, (a, b, col, ls) in pairs.items():
            d = _absdiff(a[name], b[name], angle)
            stats[f"{name}: {lab_pair}"] = {
                "rms": float(np.sqrt(np.mean(d**2))),
                "max": float(d.max()),
                "rms_last_1s": float(np.sqrt(np.mean(d[t >= t[-1] - 1.0] ** 2))),
                "exactly_zero_fraction": float(np.mean(d == 0.0)),
            }
            ax.semilogy(t, np.maximum(d, floor), color=col, ls=ls, lw=0.8, label=lab_pair)
        ax.set_ylabel(f"|Δ {lab}|")
        ax.set_ylim(floor * 0.5, None)
        ax.grid(alpha=0.3, which="both")
    axes[0].legend(loc="lower right", fontsize=7, ncol=2)
    axes[0].set_title("Trapezoidal-cumulative vs Tustin, Ts = 0.25 ms, 10 s, closed loop, dip 1.0-1.3 s\n"
                      f"(exact zeros drawn at {floor:g})", fontsize=9)
    axes[-1].set_xlabel("t [s]")
    fig.tight_layout()
    path = FIG_DIR / "sdc_cumulative_vs_tustin.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path.name, stats


def main() -> int:
    FIG_DIR.mkdir(parents=True, exist_ok=True)
    t_start = time.time()
    out: dict = {"plant": {"z_g": [ZG.real, ZG.imag], "dip": [T_DIP, T_CLEAR, V_DIP], "delay_samples": 1},
                 "params": "ViscParams() defaults", "figures": []}

    t_end = 2.0
    tc, ref = continuous(t_end)
    t67, (tus, eul) = discrete([("tustin", np.float64), ("euler", np.float64)], 0.67e-3, t_end)
    out["tustin_0.67ms_vs_continuous"] = rms_vs_ref(t67, tus, tc, ref)
    out["euler_0.67ms_vs_continuous"] = rms_vs_ref(t67, eul, tc, ref)
    out["figures"].append(fig_tustin_vs_continuous(tc, ref, t67, tus))
    out["figures"].append(fig_euler_vs_tustin(tc, ref, t67, tus, eul))

    configs = [("tustin", np.float64), ("trapezoid_cumulative", np.float64),
               ("tustin", np.float32), ("trapezoid_cumulative", np.float32)]
    t25, runs = discrete(configs, 0.25e-3, 10.0)
    name, stats = fig_cumulative_vs_tustin(t25, runs)
    out["figures"].append(name)
    out["cumulative_vs_tustin_0.25ms_10s"] = stats
    out["final_values_10s"] = {f"{m}-{np.dtype(d).name}": {"u": float(r["u"][-1]), "delta": float(r["delta"][-1]),
                                                          "e": float(r["e"][-1]), "v": float(r["v"][-1])}
                               for (m, d), r in zip(configs, runs)}
    out["runtime_s"] = round(time.time() - t_start, 1)
    print(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
