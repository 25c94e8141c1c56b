"""A deliberately small plant model for network-focused runs (``plant.model: minimal``).

Each turbine is its grid-side filter inductor (a dq dynamic phasor) between the converter voltage
and an ideal 1 p.u. bus: ``(L_f/ω0) di/dt = v_conv − v − (R_f + j L_f) i``. In ``grid_following``
mode a PI current loop tracks the turbine's P reference at unity power factor; in ``remote`` mode
the converter applies the last received control output and falls back to grid following after
``remote_loss_fallback_s`` without one. What it applies is ``remote_apply``: ``i_ref`` (default) —
the SDC's limited current reference, tracked by the converter's local current loop — or ``v_ref``
— the SDC's converter voltage reference directly (the SDC then closes the inner current loop over
the network; with the userspace datapath's delay jitter this loop loses its phase margin at about
3 ms of delay, see docs/architecture.md). The converter voltage is limited to ``v_conv_max`` and an
over-current above ``trip_current`` trips the converter back to grid following (counted). It has the same interface as :class:`plant.sim.Plant`
(the full farm) so the real-time service can drive either; use it when the question is about
packets, not about the grid (it runs 50 turbines far faster than real time).
"""

from __future__ import annotations

import numpy as np

from sdvisc.vocabulary import F_NOMINAL_HZ, FILTER_R_F_PU, FILTER_X_F_PU, OMEGA0

MODES = ("grid_following", "remote")


class MinimalPlant:
    """N turbines on an infinite bus; per-unit on the turbine rating, common synchronous frame."""

    def __init__(self, n_turbines: int, step_s: float = 0.67e-3, *, l_f: float = FILTER_X_F_PU, r_f: float = FILTER_R_F_PU,
                 p_ref: float = 0.8, remote_loss_fallback_s: float = 0.1, remote_apply: str = "i_ref",
                 v_conv_max: float = 1.3, trip_current: float = 2.0, k_current: float = 0.5) -> None:
        if remote_apply not in ("i_ref", "v_ref"):
            raise ValueError(f"remote_apply must be 'i_ref' or 'v_ref', got {remote_apply!r}")
        self.remote_apply = remote_apply
        self.v_conv_max = v_conv_max
        self.trip_current = trip_current
        self.k_current = k_current
        self.trips = np.zeros(n_turbines, dtype=np.int64)
        self.n = n_turbines
        self.step_s = step_s
        self.l_f, self.r_f = l_f, r_f
        self.t = 0.0
        self.k = 0
        self.v_grid = 1.0 + 0j
        self.p_ref = np.full(n_turbines, p_ref)
        self.i = self.p_ref.astype(complex)  # steady state at unity power factor
        self.v_conv = self.v_grid + (self.r_f + 1j * self.l_f) * self.i
        self.mode = np.zeros(n_turbines, dtype=np.int8)  # index into MODES
        self.remote_v = self.v_conv.copy()
        self.remote_i = self.i.copy()
        self.remote_age = np.zeros(n_turbines)
        self.remote_loss_fallback_s = remote_loss_fallback_s
        self.fallbacks = np.zeros(n_turbines, dtype=np.int64)

    # -------------------------------------------------------------- control inputs
    def set_mode(self, index: int, mode: str) -> None:
        self.mode[index] = MODES.index(mode)
        if mode == "remote":
            self.remote_v[index] = self.v_conv[index]
            self.remote_i[index] = self.i[index]
            self.remote_age[index] = 0.0

    def apply_remote(self, index: np.ndarray, v_ref_d: np.ndarray, v_ref_q: np.ndarray,
                     i_ref_d: np.ndarray | None = None, i_ref_q: np.ndarray | None = None) -> None:
        self.remote_v[index] = v_ref_d + 1j * v_ref_q
        if i_ref_d is not None and i_ref_q is not None:
            self.remote_i[index] = i_ref_d + 1j * i_ref_q
        self.remote_age[index] = 0.0

    def set_grid_voltage(self, magnitude: float) -> None:
        self.v_grid = complex(magnitude)

    def get_grid_voltage(self) -> float:
        return float(abs(self.v_grid))

    def load_step(self, mw: float) -> None:
        """No load model on an infinite bus; accepted so scenarios run unchanged."""

    def set_scr(self, value: float) -> None:
        """An infinite bus has no SCR; accepted so scenarios run unchanged."""

    def fault(self, on: bool, **_) -> None:
        self.v_grid = complex(0.3 if on else 1.0)

    # -------------------------------------------------------------- dynamics
    def _current_control(self, i_ref: np.ndarray) -> np.ndarray:
        """Local current loop: feed-forward of grid voltage and filter drop plus a proportional term."""
        return self.v_grid + (self.r_f + 1j * self.l_f) * i_ref + self.k_current * (i_ref - self.i)

    def step(self) -> None:
        remote = self.mode == 1
        self.remote_age[remote] += self.step_s
        lost = remote & (self.remote_age > self.remote_loss_fallback_s)
        if lost.any():
            self.fallbacks[lost] += 1
            self.mode[lost] = 0
        v_gfl = self._current_control(self.p_ref / np.conj(self.v_grid) + 0j * self.i)
        v_remote = self.remote_v if self.remote_apply == "v_ref" else self._current_control(self.remote_i)
        v_conv = np.where(self.mode == 1, v_remote, v_gfl)
        mag = np.abs(v_conv)
        self.v_conv = np.where(mag > self.v_conv_max, v_conv * (self.v_conv_max / np.maximum(mag, 1e-12)), v_conv)
        # exact solution of the linear filter over one step with v_conv held (zero-order hold)
        z = self.r_f + 1j * self.l_f
        i_ss = (self.v_conv - self.v_grid) / z
        self.i = i_ss + (self.i - i_ss) * np.exp(-(OMEGA0 / self.l_f) * z * self.step_s)
        over = (self.mode == 1) & (np.abs(self.i) > self.trip_current)
        if over.any():  # over-current protection: block remote control, back to grid following
            self.trips[over] += 1
            self.mode[over] = 0
        self.k += 1
        self.t = self.k * self.step_s

    # -------------------------------------------------------------- outputs
    def measurements(self) -> dict[str, np.ndarray]:
        v = np.full(self.n, self.v_grid)
        s = v * np.conj(self.i)
        return {"v_d": v.real, "v_q": v.imag, "i_d": self.i.real, "i_q": self.i.imag, "p": s.real, "q": s.imag,
                "v_dc": np.ones(self.n), "omega_meas": np.ones(self.n)}

    def outputs(self) -> dict[str, np.ndarray | float]:
        """All this model has: what :meth:`recorded` returns."""
        return self.recorded()

    def recorded(self) -> dict[str, np.ndarray | float]:
        """What ``timeseries.csv`` holds (plant.service.recorder), as :meth:`plant.sim.Plant.recorded`."""
        m = self.measurements()
        return {"t": self.t, "v_pcc": abs(self.v_grid), "f_pcc_hz": F_NOMINAL_HZ, "p": m["p"], "q": m["q"],
                "i_mag": np.abs(self.i), "mode": self.mode.copy()}
