"""The wind power plant's reactive-power/voltage controller at the PCC, after the structure of IEC
61400-27-1:2015 Annex D "WPP control" (reactive power control module; the public reference
implementation read for its structure is Dynawo's ``BaseWPPQControl``/``WPPQControl2015``), with the
turbines' Q limitation (the standard's QLimitation module) where the per-turbine order is formed.

    measurement:   u_f' = (|V_pcc| - u_f)/T_WPufiltq,   q_f' = (Q_WP - q_f)/T_WPqfiltq   (continuous,
                   exact between calls: the input held over the call interval)
    error:         e = v_ref - u_f - K_WPqu q_f          (voltage control with reactive droop)
                   e = q_ref - q_f                       (reactive power control)
    PI:            x(k+1) = x(k) + K_IWPx e T_s,  y = clip(K_PWPx e + x, x_min, x_max)  (sampled at T_s;
                   x stops when y is clipped and e pushes further out: anti-windup)
    reference:     lag 1/(1 + s T_xfv) (discretised exactly at T_s), rate limit dX_refmax, clip
    dip freeze:    while u_f < u_WPqdip (the FRT flag, released only when u_f >= u_release: its
                   hysteresis) the integrator and the output are frozen (held)
    communication: the order reaches the turbines T_comm after its sample (transport delay)
    QLimitation:   each turbine's order clipped to its Q limit at its terminal voltage (limit falls
                   linearly from q_max at u_qlim_knee to 0 at u_qlim_zero), the limit through the
                   turbine's Q order lag T_qlim (evaluated at every call: without the lag a steep limit
                   evaluated every 6.7 ms chatters at its own Nyquist frequency)

Q_WP is the farm's applied Q order (the mean of the per-turbine orders after the Q limitation, on the
turbine rating): the steady state is V_pcc = v_ref - K_WPqu Q within the limits. Pure: the plant hands
it the PCC voltage, the turbine terminal voltages and the time; nothing here reads a clock (``now`` in
seconds of simulated time). ``period_s`` = 0 reproduces the controller before issue 39 (updated at
every call with h = the time since the last one, no filter, delay, freeze or Q limitation:
:func:`legacy_params`).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import replace

import numpy as np

from plant.params import WppParams

EPS_T = 1e-9  # s: time comparisons (sample instants fall on float sums of the step)


def legacy_params(params: WppParams | None = None) -> WppParams:
    """The controller as it was before issue 39: integrated at every call of the plant (its slow-term
    hold, 6.7 ms at the 0.67 ms step), no measurement filter, no lag, no rate limit, no communication
    delay, no dip freeze, no turbine Q limitation (the old/new comparison of F7)."""
    return replace(params or WppParams(), period_s=0.0, t_ufilt_s=0.0, t_qfilt_s=0.0, t_xfv_s=0.0,
                   dq_max_per_s=math.inf, comm_delay_s=0.0, u_dip=0.0, u_release=0.0,
                   u_qlim_knee=math.inf, u_qlim_zero=math.inf, t_qlim_s=0.0)


def _lag(y: float, u: float, dt: float, tau: float) -> float:
    """First-order lag advanced by ``dt`` with ``u`` held (exact); tau = 0: y = u."""
    if tau <= 0.0:
        return u
    return u + (y - u) * math.exp(-dt / tau)


def q_limit_at(v_terminal: np.ndarray, p: WppParams) -> np.ndarray:
    """Each turbine's capacitive Q limit at its terminal voltage (QLimitation): q_max up to
    ``u_qlim_knee``, falling linearly to 0 at ``u_qlim_zero`` and beyond."""
    if not math.isfinite(p.u_qlim_knee):
        return np.full(np.shape(v_terminal), p.q_max)
    frac = (p.u_qlim_zero - np.asarray(v_terminal, dtype=float)) / (p.u_qlim_zero - p.u_qlim_knee)
    return p.q_max * np.clip(frac, 0.0, 1.0)


class WppController:
    """State and sampled update of the plant's Q/V controller (see the module's docstring)."""

    def __init__(self, params: WppParams):
        self.p = params
        self.x = 0.0  # integrator, p.u. Q
        self.q = 0.0  # the order leaving the controller (after lag, rate and absolute limits), p.u.
        self.q_pi = 0.0  # the PI's limited output (before the lag)
        self.q_turbines = 0.0  # the order at the turbines (after the communication delay)
        self.q_applied = 0.0  # mean applied order after the turbines' Q limitation: Q_WP
        self.u_f = 1.0  # filtered |V_pcc|
        self.q_f = 0.0  # filtered Q_WP
        self.frozen = False  # the dip flag (FRT state)
        self.q_lim: np.ndarray | None = None  # each turbine's Q limit through its order lag (None: not yet)
        self._dt = 0.0  # time since the previous call
        self.t_meas: float | None = None  # time of the last measurement (filters advanced to it)
        self.t_next: float | None = None  # next sample instant
        self.t_last: float | None = None  # last sample instant
        self._sent: deque[tuple[float, float]] = deque()  # (delivery time, order) in flight
        self.samples = 0  # samples taken (tests, diagnostics)

    # ---------------------------------------------------------------- the controller
    def error(self, u: float, q: float) -> float:
        p = self.p
        return p.v_ref - u - p.droop * q if p.mode == "voltage" else p.q_ref - q

    def _gains(self) -> tuple[float, float]:
        """(K_PWPx, K_IWPx) of the present mode: the Q loop has its own (WppParams.k_p_q, k_i_q)."""
        p = self.p
        return (p.k_p_q, p.k_i_q) if p.mode == "reactive_power" else (p.k_p, p.k_i)

    def order(self, e: float) -> float:
        """The PI's output for the error ``e`` with the present integrator (clipped)."""
        return float(np.clip(self._gains()[0] * e + self.x, -self.p.q_max, self.p.q_max))

    def _measure(self, now: float, v_pcc: float) -> None:
        if self.t_meas is None:  # not settled: the filters start at the first measurement
            self.u_f, self.q_f = v_pcc, self.q_applied
        dt = self._dt = 0.0 if self.t_meas is None else max(now - self.t_meas, 0.0)
        self.u_f = _lag(self.u_f, v_pcc, dt, self.p.t_ufilt_s)
        self.q_f = _lag(self.q_f, self.q_applied, dt, self.p.t_qfilt_s)
        self.t_meas = now
        if self.u_f < self.p.u_dip:
            self.frozen = True
        elif self.u_f >= self.p.u_release:
            self.frozen = False

    def _sample(self, h: float) -> None:
        """One controller cycle of length ``h`` (the period, or the call interval in legacy mode)."""
        p = self.p
        self.samples += 1
        if self.frozen:  # integrator and output held during the dip
            return
        e = self.error(self.u_f, self.q_f)
        k_p, k_i = self._gains()
        y_unclipped = k_p * e + self.x
        at_limit = abs(y_unclipped) >= p.q_max and y_unclipped * e > 0.0
        if not at_limit:
            self.x += k_i * e * h
        self.q_pi = self.order(e)
        lagged = _lag(self.q, self.q_pi, h, p.t_xfv_s)
        step = p.dq_max_per_s * h if math.isfinite(p.dq_max_per_s) else math.inf
        self.q = float(np.clip(np.clip(lagged, self.q - step, self.q + step), -p.q_max, p.q_max))

    def update(self, now: float, v_pcc: float, v_terminals: np.ndarray | None = None):
        """Advance to ``now``: filters, every sample instant passed, the orders delivered by now;
        return the turbines' orders (an array with ``v_terminals``, else the common order)."""
        p = self.p
        self._measure(now, v_pcc)
        if self.t_next is None:
            self.t_next, self.t_last = now, now
        if p.period_s <= 0.0:  # legacy: a cycle at every call, h = the time since the last
            self._sample(now - self.t_last)
            self.t_last = now
            self._sent.append((now, self.q))
        else:
            while now + EPS_T >= self.t_next:
                self._sample(p.period_s)
                self.t_last = self.t_next
                self._sent.append((self.t_next + p.comm_delay_s, self.q))
                self.t_next = self.t_last + p.period_s
        while self._sent and self._sent[0][0] <= now + EPS_T:
            self.q_turbines = self._sent.popleft()[1]
        if v_terminals is None:
            self.q_applied = self.q_turbines
            return self.q_turbines
        lim = q_limit_at(v_terminals, p)
        if self.q_lim is None or len(self.q_lim) != len(lim) or p.t_qlim_s <= 0.0:
            self.q_lim = lim
        else:  # through the turbine's Q order lag (the limit is applied in the turbine, not at this call rate)
            self.q_lim = lim + (self.q_lim - lim) * math.exp(-self._dt / p.t_qlim_s)
        q = np.minimum(self.q_turbines, self.q_lim)
        self.q_applied = float(np.mean(q)) if len(q) else self.q_turbines
        return q

    def settle_at(self, q: float, now: float, v_pcc: float | None = None) -> None:
        """Start in steady state at the order ``q`` (e = 0 unless clipped): every state at q, the
        voltage filter at ``v_pcc`` (default: the droop line's v_ref - droop q), nothing in flight."""
        p = self.p
        q = float(np.clip(q, -p.q_max, p.q_max))
        self.x = self.q = self.q_pi = self.q_turbines = self.q_applied = self.q_f = q
        self.u_f = p.v_ref - p.droop * q if v_pcc is None else float(v_pcc)
        self.frozen = False
        self.q_lim = None
        self.t_meas = self.t_last = self.t_next = now
        self._sent.clear()
