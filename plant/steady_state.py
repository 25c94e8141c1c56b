"""The plant's steady state before t = 0: the load flow with every turbine a PQ source, the plant
controller's (WPP's) settled order, and the initial state of every device from them (a mixin of
:class:`plant.sim.Plant`, which owns ``net``, ``tb``, ``sc``, ``wpp``, ``layout`` and ``params``)."""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq, root

from plant.layout import GRID_ANGLE, GRID_PM, GRID_SPEED, PLL_ANGLE

LOSS_PASSES = 6  # the load flow's passes for the filter loss (error ~0.006^6 of it)
WPP_SEARCH_STEP = 0.05  # p.u. Q: the plant controller's steady-state search walks in these steps


class SteadyState:
    """Load flow and initial state of the plant."""

    def _load_flow(self, start: np.ndarray | None = None):
        """Load flow of the present P*/Q* with every turbine a PQ source and the SC unloaded, from a
        flat start or the node voltages ``start``: (turbine terminal voltages, turbine currents,
        every node voltage)."""
        n, net, g = self.n, self.net, self.params.grid
        p_me = self.tb.p_star(self.tb.wr0())  # the machine side's power: P_conv in steady state
        q_star = self.tb.q_cmd + self.tb.q_wpp
        r_f = self.params.turbine.rf

        def terminal_currents(v):
            """i with Re(v conj(i)) = P_me - r_f |i|^2 (the filter's loss), Im = Q*: a few passes of
            the fixed point (each shrinks the error by ~2 r_f |i|^2 / P ~ 0.006)."""
            i = np.conj((p_me + 1j * q_star) / v)
            for _ in range(LOSS_PASSES):
                i = np.conj((p_me - r_f * np.abs(i) ** 2 + 1j * q_star) / v)
            return i

        def node_voltages(vall):
            v = np.where(net.plugged, vall[:n], 1.0)
            return net.solve(net.injections(terminal_currents(v), g.e_grid, vall[net.sc], 0.0))

        def residual(x):
            vall = x[:net.n_nodes] + 1j * x[net.n_nodes:]
            r = node_voltages(vall) - vall
            return np.r_[r.real, r.imag]

        # Newton-type solve (the plain fixed point V = Z I(V) can cycle when the farm absorbs Q)
        x0 = np.r_[np.ones(net.n_nodes), np.zeros(net.n_nodes)] if start is None else np.r_[start.real, start.imag]
        sol = root(residual, x0, method="hybr", tol=1e-14)
        vall = sol.x[:net.n_nodes] + 1j * sol.x[net.n_nodes:]
        if np.max(np.abs(residual(sol.x))) > 1e-10:
            raise RuntimeError(f"the initial load flow did not converge ({sol.message})")
        v = np.where(net.plugged, vall[:n], 1.0)
        i = terminal_currents(v)
        return v, i, vall

    def _settle_wpp(self) -> None:
        """The plant controller's steady-state order: in voltage mode Q* with |V_pcc| = v_ref - droop Q*
        (brentq on the load flow), or its limit where none within the limits; in reactive-power mode q_ref."""
        wp = self.params.wpp
        q = float(np.clip(wp.q_ref, -wp.q_max, wp.q_max)) if wp.mode == "reactive_power" else self._droop_order()
        self.tb.q_wpp[:] = q * self._wpp_mask
        self.wpp.settle_at(q, self.t, abs(self._load_flow()[2][self.net.pcc]))

    def _droop_order(self) -> float:
        """Voltage mode's steady order: Q* with |V_pcc| = v_ref - droop Q* (brentq on the load flow),
        or its limit where none lies within the limits."""
        wp = self.params.wpp

        def mismatch(q: float) -> float:
            self.tb.q_wpp[:] = q * self._wpp_mask
            return abs(self._load_flow()[2][self.net.pcc]) - (wp.v_ref - wp.droop * q)

        # the mismatch rises with q: walk from 0 towards the side that closes it until it changes sign
        direction = 1.0 if mismatch(0.0) < 0.0 else -1.0
        q_last, q = 0.0, 0.0
        while True:
            q = min(q + WPP_SEARCH_STEP, wp.q_max) if direction > 0 else max(q - WPP_SEARCH_STEP, -wp.q_max)
            if mismatch(q) * direction > 0.0:
                return brentq(mismatch, min(q_last, q), max(q_last, q), xtol=1e-12)
            if abs(q) >= wp.q_max:
                return q  # at its limit
            q_last = q

    def _init_steady_state(self) -> None:
        net, g = self.net, self.params.grid
        if self.wpp is not None:
            self._settle_wpp()
        v, i, vall = self._load_flow()
        lay = self.layout
        self.X = np.zeros(self.size, dtype=complex)
        self.layout.turbines(self.X)[:] = self.tb.init_state(v, i)
        vreg = abs(vall[net.pcc]) if self.params.condenser.avr_bus == "pcc" else abs(vall[net.sc])
        self.X[lay.condenser:lay.grid] = self.sc.init_state(vall[net.sc], vreg)
        self.X[lay.grid + GRID_ANGLE] = 0.0
        self.X[lay.grid + GRID_SPEED] = 1.0
        ig = (g.e_grid - vall[net.pcc]) * net.y_grid
        self.pm0 = (g.e_grid * np.conj(ig)).real * g.s_base_mva / g.s_grid_mva
        self.X[lay.grid + GRID_PM] = self.pm0
        self.X[lay.pcc_pll + PLL_ANGLE] = np.angle(vall[net.pcc])
        self._v_pcc_last = vall[net.pcc]  # PCC voltage of the last network solve (load linearisation)
        net.start_history(vall, g.e_grid, self.sc.e_net(self.X[lay.condenser:lay.grid]) if net.sc_connected else 0j)
        self._cache = None
