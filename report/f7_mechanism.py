"""F7's second look (issue 39 item 1): the quasi-static (slow-ramp) boundary beside the step one, what
each loss of stability is (limit cycle, growing oscillation, sag out of the band), and a linearised
check of the damping at the boundary.

Ramp: the SCR steps from 7.14 to ``RAMP_FROM`` at 1 s (the step's own transient over by
``RAMP_START``), then falls linearly at ``rate`` per second, applied as a staircase of ``RAMP_DT``
steps (a step of rate x RAMP_DT, 0.0025 at the full rate: far below the bisection's tolerance). The
rate is slow against the slowest closed loop the farm has, the plant controller's (time constant
~0.5-1 s): the SCR moves by ≤ 0.025 within it, so the farm follows its operating point (quasi-static)
— the ramp boundary is where that operating point stops being stable, the step boundary where a jump
stops landing on it. The loss is the first 1 s window (checked every 0.5 s) whose V_pcc is not
"stable" (report/stability.py); the SCR reported is the one at the window's start.

Linearisation, two parts at a state the ramp passed through (a quasi-static operating point; its
|f(x)| is reported — near the loss it is no equilibrium any more): (1) the Jacobian of the plant's
right-hand side (``Plant.rhs_real``, central differences) with the plant controller's order held
(its loop is sampled at 0.1 s and outside the right-hand side): the continuous plant (the turbines'
current loops and PLLs, the ViSC, the SC, the network); its least-damped oscillatory mode (0.5-20
Hz) says whether that loses damping at the boundary; (2) the sampled plant controller's own loop
(``wpp_loop_modes``: a discrete model, the farm as its static gain dV/dq from the load flow).
"""

from __future__ import annotations

import numpy as np

from plant.linearise import jacobian
from report.stability import LAST_S, PTP_DAMPED, V_NORMAL, stability

T_EVENT = 1.0
RAMP_FROM = 4.0  # SCR the ramp starts from (above every step boundary of the IEC controller)
RAMP_START = 3.0  # s: the ramp starts (2 s after the step to RAMP_FROM)
RAMP_DT = 0.1  # s: the staircase's step
RAMP_FLOOR = 1.0  # the ramp stops here
AFTER_LOSS_S = 2.5  # s: run on after the loss, to show what the loss is
GAIN_AFTER_S = 0.2  # s: the farm's response to the plant controller's order read this long after a step
FAST_HZ = 10.0  # Hz: an oscillation faster than this around a sagged V_pcc is the converters' limit chatter
OSC_BAND_HZ = (0.5, 20.0)  # oscillatory modes considered in the linearised check


def ramp_settings(quick: bool) -> float:
    """Ramp rate [SCR/s]: 0.025 in full (the SCR moves 0.025 within the plant controller's ~1 s),
    0.05 with --quick."""
    return 0.05 if quick else 0.025


def ramp_run(plant, rate: float, snapshot_scrs=()) -> dict:
    """Run ``plant`` down the ramp until it is no longer stable (or RAMP_FLOOR): the record (every 10th
    step) with ``scr`` per sample, ``loss_scr`` (None: stable to the floor), ``loss_t`` and the plant
    states at the SCRs ``snapshot_scrs`` passed on the way (``snapshots``: {scr: (state, the plant
    controller's per-turbine applied orders, its order at the turbines)})."""
    rec: dict[str, list] = {}
    snaps: dict[float, tuple[np.ndarray, np.ndarray]] = {}
    want = sorted(snapshot_scrs, reverse=True)
    scr, loss_t, loss_scr, t_check = 7.14, None, None, RAMP_START + LAST_S
    scr_hist: list[tuple[float, float]] = []

    def scr_at(t: float) -> float:
        if t < T_EVENT:
            return 7.14
        if t < RAMP_START:
            return RAMP_FROM
        k = np.floor((t - RAMP_START) / RAMP_DT + 1e-9)
        return max(RAMP_FROM - rate * RAMP_DT * k, RAMP_FLOOR)

    with np.errstate(all="ignore"):
        while True:
            t_next = plant.t + RAMP_DT
            s = scr if loss_t is not None else scr_at(plant.t + 1e-9)  # held at the loss's SCR after it
            if s != scr:
                while want and scr <= want[0] + 1e-9 and loss_t is None:  # settled RAMP_DT at scr
                    snaps[want.pop(0)] = (plant.state_real().copy(), plant.tb.q_wpp.copy(),
                                          None if plant.wpp is None else plant.wpp.q_turbines)
                scr = s
                plant.set_scr(s)
            r = plant.run_offline(t_next, record_every=10)
            for k, v in r.items():
                rec.setdefault(k, []).append(v)
            scr_hist.append((plant.t, scr))
            if loss_t is None and plant.t >= t_check:
                t = np.concatenate(rec["t"])
                v = np.concatenate(rec["v_pcc"])
                w = t >= plant.t - LAST_S
                v_wt = np.concatenate(rec["v_wt"])[w] if "v_wt" in rec else None
                st = stability(t[w], v[w], t[w][0] - 1.0, v_wt)
                if not st.stable:
                    loss_t = float(t[w][0])
                    loss_scr = scr_at(loss_t)
                t_check += 0.5
            if loss_t is not None and plant.t >= loss_t + LAST_S + AFTER_LOSS_S:
                break
            if loss_t is None and scr <= RAMP_FLOOR and plant.t > t_check + LAST_S:
                break
    out = {k: np.concatenate(v) for k, v in rec.items()}
    hist = np.array(scr_hist)
    out["scr"] = np.interp(out["t"], hist[:, 0], hist[:, 1])
    out.update(loss_scr=loss_scr, loss_t=loss_t, snapshots=snaps, rate=rate)
    return out


def dominant_hz(t: np.ndarray, v: np.ndarray) -> float:
    """Frequency of the largest spectral peak of v - mean above 0.3 Hz (nan if none)."""
    if len(v) < 8 or not np.all(np.isfinite(v)):
        return float("nan")
    dt = float(np.median(np.diff(t)))
    spec = np.abs(np.fft.rfft((v - np.mean(v)) * np.hanning(len(v))))
    f = np.fft.rfftfreq(len(v), dt)
    ok = f >= 0.3
    return float(f[ok][np.argmax(spec[ok])]) if np.any(ok) else float("nan")


def mechanism(t: np.ndarray, v: np.ndarray, t_from: float, v_wt: np.ndarray | None = None) -> str:
    """What the trace after ``t_from`` shows: diverged, a growing oscillation (loss of damping), a
    limit cycle (sustained, bounded: last second's peak-to-peak within ±30 % of the one before), a
    sag out of the band (damped, current/transfer limited), a terminal over 1.1, or stable."""
    after = t >= t_from
    t, v = t[after], v[after]
    if len(t) < 4 or not np.all(np.isfinite(v)):
        return "diverged"
    last = t >= t[-1] - LAST_S
    before = (t >= t[-1] - 2 * LAST_S) & ~last
    ptp1 = float(np.ptp(v[last]))
    ptp0 = float(np.ptp(v[before])) if np.any(before) else ptp1
    f = dominant_hz(t[last | before], v[last | before])
    if ptp1 >= PTP_DAMPED and f > FAST_HZ and not V_NORMAL[0] <= np.mean(v[last]) <= V_NORMAL[1]:
        return (f"sag out of the band (mean V_pcc {np.mean(v[last]):.2f}) with a {f:.0f} Hz chatter of "
                f"p-p {ptp1:.3f} (the converters at their current limit / FRT)")
    if ptp1 >= PTP_DAMPED:
        kind = "growing oscillation (loss of damping)" if ptp1 > 1.3 * ptp0 else "limit cycle (sustained, bounded)"
        return f"{kind}, {f:.1f} Hz, V_pcc {np.min(v[last]):.2f}-{np.max(v[last]):.2f}"
    st = stability(t, v, t[0] - 1.0, None if v_wt is None else v_wt[after])
    if not st.in_band:
        return f"sag out of the band (damped at {v[-1]:.2f} p.u.: current/transfer limited)"
    if st.terminal_over:
        return f"terminal over {st.v_terminal_max:.3f} p.u. (damped, V_pcc {v[-1]:.2f})"
    return "stable"


def jacobian_modes(plant, state: np.ndarray, band_hz=OSC_BAND_HZ) -> dict:
    """The least-damped oscillatory mode (``band_hz``) and the largest real part of the Jacobian of
    ``plant``'s right-hand side at ``state`` (central differences, relative step 1e-6); the plant's
    state is restored after."""
    y0 = np.asarray(state, dtype=float)
    jac = jacobian(plant, y0)
    with np.errstate(all="ignore"):
        residual = float(np.max(np.abs(plant.rhs_real(0.0, y0))))
    eig = np.linalg.eigvals(jac)
    hz = np.abs(eig.imag) / (2 * np.pi)
    osc = eig[(hz >= band_hz[0]) & (hz <= band_hz[1])]
    if len(osc) == 0:
        return {"mode": None, "max_real": float(np.max(eig.real)), "residual": residual}
    m = osc[np.argmax(osc.real / np.abs(osc))]
    return {"mode_hz": float(abs(m.imag) / (2 * np.pi)), "damping_ratio": float(-m.real / abs(m)),
            "mode_real": float(m.real), "max_real": float(np.max(eig.real[np.abs(eig) > 1e-3])),
            "residual": residual}


def describe_modes(m: dict) -> str:
    if m.get("mode_hz") is None:
        return "no oscillatory mode in the band"
    return (f"least-damped mode {m['mode_hz']:.2f} Hz, ζ = {m['damping_ratio']:.3f} (Re {m['mode_real']:.2f}/s); "
            f"largest Re of all modes {m['max_real']:.3f}/s; |f(x)| at the point {m['residual']:.1e}")


def wpp_loop_poles(wp, k: float) -> np.ndarray:
    """Poles (z) of the sampled plant controller ``wp`` (WppParams) closed over a farm of loop gain
    ``k`` = c (G + droop) (see :func:`wpp_loop_modes`). The measurement at cycle k sees the order of
    cycle k - n, n = floor(T_comm/T_s) + 1 (plant/wpp.py: the order is delivered T_comm after its
    cycle, after that call's measurement): e_k = -k y_{k-n}, x_k = x_{k-1} + K_i T_s e_k,
    y_k = a y_{k-1} + (1 - a)(x_k + K_p e_k), a = exp(-T_s/T_xfv); state [x_{k-1}, y_{k-1} .. y_{k-n}]."""
    t_s = wp.period_s
    a = float(np.exp(-t_s / wp.t_xfv_s)) if wp.t_xfv_s > 0 else 0.0
    n = int(np.floor(wp.comm_delay_s / t_s + 1e-9)) + 1
    m = np.zeros((n + 1, n + 1))
    m[0, 0], m[0, n] = 1.0, -wp.k_i * t_s * k  # x_k
    m[1, 0], m[1, 1] = 1.0 - a, a  # y_k
    m[1, n] += -(1.0 - a) * (wp.k_i * t_s + wp.k_p) * k
    for j in range(2, n + 1):  # the shift register y_{k-j+1} <- y_{k-j+1}
        m[j, j - 1] = 1.0
    return np.linalg.eigvals(m)


def wpp_loop_modes(plant, q_applied: np.ndarray, q_order: float | None, state: np.ndarray) -> dict:
    """The sampled plant controller's own loop, linearised around an operating point of ``plant``
    (its SCR and the applied orders ``q_applied``): the farm as a gain G = d|V_pcc|/dq (the plant
    run GAIN_AFTER_S from ``state`` with every farm turbine's order moved by ±0.01 together, the
    controller out: the turbines' current loops, PLLs and the network settle within a cycle of 0.1
    s; central difference, so a slow drift of the state cancels), cut by the share c of turbines not held
    by their Q limitation (for them the order does not reach the grid: the loop opens); the
    controller's cycle as :func:`wpp_loop_poles` (the filters of 0.01 s settle within a cycle). Returns G, c, the largest |z| and its frequency; |z| > 1: the
    controller's loop is unstable at this operating point."""
    wp = plant.params.wpp
    mask = plant._wpp_mask
    base = plant.tb.q_wpp.copy()
    dq = 0.01
    v = []
    controller, k0 = plant.wpp, plant.k
    plant.wpp = None  # the order held at base +- dq (the Q limitation is the share c below)
    try:
        for sign in (1.0, -1.0):
            plant.set_state_real(state)
            plant.k = k0
            plant.tb.slow = None
            plant.tb.q_wpp[:] = base + sign * dq * mask
            with np.errstate(all="ignore"):
                r = plant.run_offline(plant.t + GAIN_AFTER_S, record_every=10)
            v.append(float(np.mean(r["v_pcc"][r["t"] >= r["t"][-1] - 0.05])))
    finally:
        plant.wpp, plant.k = controller, k0
        plant.tb.q_wpp[:] = base
        plant.set_state_real(state)
    g = (v[0] - v[1]) / (2 * dq)
    free = q_applied[mask] >= (q_order if q_order is not None else -np.inf) - 1e-4
    c = float(np.mean(free)) if np.any(mask) else 0.0
    z = wpp_loop_poles(wp, c * (g + wp.droop))
    zm = z[np.argmax(np.abs(z))]
    t_s = wp.period_s
    return {"gain_dv_dq": float(g), "share_free": c, "z_max": float(abs(zm)),
            "z_hz": float(abs(np.angle(zm)) / (2 * np.pi * t_s))}


def describe_wpp_loop(m: dict) -> str:
    return (f"plant-controller loop: dV/dq {m['gain_dv_dq']:.3f}, {100 * m['share_free']:.0f} % of turbines "
            f"free of their Q limitation, largest |z| {m['z_max']:.3f} at {m['z_hz']:.2f} Hz "
            f"({'unstable' if m['z_max'] > 1 + 1e-9 else 'loop open: integrator only' if m['share_free'] == 0 else 'stable'})")
