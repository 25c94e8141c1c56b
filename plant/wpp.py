"""The wind power plant's voltage controller at the PCC (IEC 61400-27-1 WPP control, voltage mode
with reactive droop), a sampled plant-level controller: one reactive-power order Q* for every
grid-following farm turbine (p.u. on the turbine rating).

    e = v_ref - |V_pcc| - droop Q*,   Q* = clip(k_p e + x, -q_max, q_max),
    x(k+1) = x(k) + k_i e h           (forward Euler at the controller's period h; the integrator
                                       stops while Q* is clipped and e pushes further out)

Its steady state is V_pcc = v_ref - droop Q* within the limits. Pure: the plant hands it the PCC
voltage and the time; nothing here reads a clock (``now`` in seconds of simulated time).
"""

from __future__ import annotations

import numpy as np

from plant.params import WppParams


class WppController:
    """State (the integrator) and the sampled update of the plant's voltage controller."""

    def __init__(self, params: WppParams):
        self.p = params
        self.x = 0.0  # integrator, p.u. Q
        self.q = 0.0  # the present order Q*, p.u.
        self.t_last: float | None = None

    def order(self, e: float) -> float:
        """Q* for the error ``e`` with the present integrator (clipped)."""
        return float(np.clip(self.p.k_p * e + self.x, -self.p.q_max, self.p.q_max))

    def error(self, v_pcc: float, q: float) -> float:
        return self.p.v_ref - v_pcc - self.p.droop * q

    def update(self, now: float, v_pcc: float) -> float:
        """Advance to ``now`` if a period has passed since the last update; return Q*."""
        if self.t_last is None:
            self.t_last = now
        h = now - self.t_last
        if h + 1e-12 >= self.p.period_s:
            e = self.error(v_pcc, self.q)
            q_unclipped = self.p.k_p * e + self.x
            at_limit = abs(q_unclipped) >= self.p.q_max and q_unclipped * e > 0.0
            if not at_limit:
                self.x += self.p.k_i * e * h
            self.q = self.order(e)
            self.t_last = now
        return self.q

    def settle_at(self, q: float, now: float) -> None:
        """Start in steady state at the order ``q`` (e = 0 unless clipped): integrator = q."""
        self.x = float(q)
        self.q = float(np.clip(q, -self.p.q_max, self.p.q_max))
        self.t_last = now
