"""Commands and events of the plant: modes, references, remote references and their loss,
load, fault, SCR, condenser, plugs, battery (a part of :class:`plant.sim.Plant`, a mixin).

Every command invalidates the cached evaluation of the present state (``_cache``), which also
makes the next step re-evaluate the held slow terms (docs/plant.md, Integration); new remote
references (``apply_remote``, every step of a remote turbine) invalidate the evaluation only. Refactorising
commands (fault, SCR, condenser, plug) go through ``_refresh``.
"""

from __future__ import annotations

import numpy as np

from plant import kernels, turbine_kernels
from plant import turbine as T
from sdc_unit import law
from sdc_unit.params import ViscParams
from sdvisc.vocabulary import OMEGA0

_INTP, _FLOAT64 = np.dtype(np.intp), np.dtype(np.float64)


def _service_arrays(idx, refs) -> bool:
    """True for the plant service's arguments of ``apply_remote``: a 1-d ``intp`` index array and
    ``float64`` reference arrays of its shape (dtype identity: a dtype that merely compares equal
    takes the general path, with the same result)."""
    if type(idx) is not np.ndarray or idx.dtype is not _INTP or idx.ndim != 1:
        return False
    shape = idx.shape
    for r in refs:
        if type(r) is not np.ndarray or r.dtype is not _FLOAT64 or r.shape != shape:
            return False
    return True


class Commands:
    """The commands of :class:`plant.sim.Plant` (see the module docstring)."""

    def apply_remote(self, index_array, v_ref_d, v_ref_q, i_ref_d=None, i_ref_q=None) -> None:
        """Store the received references (common frame, turbine p.u.); i_ref is used only with
        ``TurbineParams.remote_apply == "i_ref"``."""
        tb = self.tb
        refs = (v_ref_d, v_ref_q, i_ref_d, i_ref_q) if i_ref_d is not None and i_ref_q is not None else (v_ref_d, v_ref_q)
        idx = index_array
        if _service_arrays(idx, refs):
            # the plant service's call, every step: one compiled loop instead of small-array numpy
            kernels.store_remote(tb.v_hold, tb.i_hold, tb.last_rx_step, idx, refs[0], refs[1], refs[-2], refs[-1],
                                 len(refs) == 4, self.k)
        else:
            idx = np.atleast_1d(np.asarray(idx, dtype=int))
            tb.v_hold[idx] = np.asarray(v_ref_d) + 1j * np.asarray(v_ref_q)
            if len(refs) == 4:
                tb.i_hold[idx] = np.asarray(i_ref_d) + 1j * np.asarray(i_ref_q)
            tb.last_rx_step[idx] = self.k
        self._references_changed()

    def _references_changed(self) -> None:
        """New remote references change only the converter voltages of the present evaluation: it
        is made again, but the held slow terms and the operating values stay (they do not depend on
        the references), as after a step; a command since the last evaluation still counts."""
        if self._cache is not None:
            self._v_nodes, self._v_nodes_k = self._cache[2]["v"], self.k  # v does not depend on the references
            self._cache = None
            self._slow_keep = True

    def _check_fallback(self) -> None:
        """Remote turbines whose references stopped (fall-back) or whose current is too high (trip)
        go back to grid following, bumplessly."""
        tb = self.tb
        rem = self._mode_info()[2]
        if not rem.size:
            return
        tp = self.params.turbine
        if tp.i_max_local > 0.0 and tp.remote_apply == "v_ref":
            self._local_current_limit(rem)
        if not kernels.remote_needs_action(self.X, rem, tb.last_rx_step, self.k, self.step_s, tp.trip_current,
                                           tp.remote_loss_fallback_s, tb.fallback_enabled):
            return  # the usual case: no current above the trip level, no reference too old
        i_mag = np.abs(self.X[T.IF * self.n + rem])  # (turbine.IF row of the state, layout.py)
        rx_step = tb.last_rx_step[rem]
        over = rem[i_mag > tp.trip_current]
        late = rem[(self.k - rx_step) * self.step_s >= tp.remote_loss_fallback_s]
        if not tb.fallback_enabled:
            late = late[:0]
        if late.size and over.size:  # (late and over are sorted and unique already)
            late = np.setdiff1d(late, over)
        if late.size or over.size:
            _, _, aux = self._eval_cached()
            both = np.concatenate([late, over])
            tb.bumpless_gfl(self.layout.turbines(self.X), aux["v"], both, aux["vconv"][both])
            tb.fell_back[late] = True
            tb.fallbacks[late] += 1
            tb.trips[over] += 1
            self._cache = None

    def _local_current_limit(self, rem) -> None:
        """The remote converters' local current limit (``TurbineParams.i_max_local``,
        ``turbine_laws.remote_current_limit``), decided at the step's start and held over the step: where the
        last received v_ref (less the turbine's active damping, within its modulation limit: as applied)
        would take the filter current
        above i_max_local within the step, the applied v_hold makes it draw that current scaled to
        i_max_local (the damping added back, the turbine subtracts it); else the received v_ref."""
        tb, tp = self.tb, self.params.turbine
        if self._cache is not None:
            v = self._cache[2]["v"]
        elif getattr(self, "_v_nodes_k", -1) == self.k:  # only the references changed since the evaluation
            v = self._v_nodes
        else:
            v = self._eval_cached()[2]["v"]
        k_ad = tp.k_ad if tb.ext_active_damping else 0.0
        if turbine_kernels.local_current_limit(self.X, np.ascontiguousarray(v, dtype=complex), rem, tb.v_sdc,
                                               tb.v_hold, tb.last_rx_step, self.k, tp.rf, tp.lf,
                                               self.step_s * OMEGA0 / tp.lf, tp.i_max_local, k_ad, tp.m_max):
            self._references_changed()

    @property
    def fallbacks(self) -> np.ndarray:
        """Per turbine: how many times remote mode fell back to grid-following (lost references)."""
        return self.tb.fallbacks

    @property
    def trips(self) -> np.ndarray:
        """Per turbine: remote-mode over-current trips back to grid-following."""
        return self.tb.trips

    def set_remote_fallback(self, enabled: bool) -> None:
        """Enable/disable the fall-back of ``remote`` turbines to grid-following on lost references."""
        self.tb.fallback_enabled = bool(enabled)

    def set_mode(self, index, mode: str) -> None:
        """Set the control mode of turbines ``index``: grid_following, hd_visc or remote (bumpless)."""
        if mode not in T.MODES:
            raise ValueError(f"mode must be one of {sorted(T.MODES)}")
        idx = np.atleast_1d(np.asarray(index, dtype=int))
        _, _, aux = self._eval_cached()
        S = self.layout.turbines(self.X)
        code = T.MODES[mode]
        if code != T.GFL:  # the machine side takes the DC link over from the grid side: its PI from P_me now
            from_gfl = idx[self.tb.mode[idx] == T.GFL]
            S[T.XD, from_gfl] = aux["pme"][from_gfl]
        if code == T.GFL:
            self.tb.bumpless_gfl(S, aux["v"], idx, aux["vconv"][idx])
        elif code == T.REMOTE:
            self.tb.v_hold[idx] = self.tb.v_sdc[idx] = aux["vconv"][idx]
            self.tb.i_hold[idx] = S[T.IF, idx]
            self.tb.last_rx_step[idx] = self.k
            self.tb.fell_back[idx] = False
        self.tb.mode[idx] = code
        new_visc = np.nonzero(self.tb.mode == T.HD_VISC)[0]
        if not np.array_equal(new_visc, self.visc_idx):
            self._init_law(new_visc, S, aux["v"])
        self._cache = None

    def _init_law(self, idx, S, v) -> None:
        """The hd_visc turbines are now ``idx``: their law state starts at the present operating point."""
        self.visc_idx = idx
        if idx.size == 0:
            self.xl = None
            return
        if self.visc_params is None:
            self.visc_params = ViscParams()
        self.xl = law.initial_state(law.Measurements(**self._meas_arrays(S, v, idx)), self.visc_params)

    def set_visc_params(self, params) -> None:
        """Replace the ViscParams used by hd_visc turbines (e.g. a new V* or droop)."""
        self.visc_params = params
        self._cache = None

    def set_battery(self, index, on: bool = True, soc: float | None = None) -> None:
        """Connect (or disconnect) the batteries of turbines ``index`` to their DC links (plant/battery.py);
        ``soc`` sets their state of charge (default: kept, initially BatteryParams.soc_init)."""
        idx = np.atleast_1d(index)
        self.tb.battery[idx] = bool(on)
        self._any_battery = bool(self.tb.battery.any())
        if soc is not None:
            self.tb.batt.soc[idx] = float(soc)
        self._cache = None

    def set_power_ref(self, index, p=None, q=None, mppt: bool = False) -> None:
        """Grid-following P*/Q* (turbine p.u.); ``mppt=True`` returns P* to the MPPT curve."""
        idx = np.atleast_1d(index)
        if p is not None:
            self.tb.p_cmd[idx] = p
            self.tb.mppt[idx] = False
        if q is not None:
            self.tb.q_cmd[idx] = q
        if mppt:
            self.tb.mppt[idx] = True
        self._cache = None

    def set_avr_ref(self, v: float) -> None:
        """Synchronous-condenser AVR voltage reference, p.u."""
        self.sc.v_ref = float(v)
        self._cache = None

    def get_avr_ref(self) -> float:
        """The AVR voltage reference now, p.u. (a relative ``set``: plant/settable.py)."""
        return float(self.sc.v_ref)

    def get_grid_emf(self) -> float:
        """The grid source EMF magnitude now, p.u."""
        return float(self.params.grid.e_grid)

    def get_grid_voltage(self) -> float:
        """Alias of get_grid_emf (interface shared with plant.minimal)."""
        return self.get_grid_emf()

    def set_grid_emf(self, e: float) -> None:
        """Grid source EMF magnitude, p.u. (a grid-side voltage step)."""
        self.params.grid.e_grid = float(e)
        self._cache = None

    def set_grid_voltage(self, magnitude: float) -> None:
        """Alias of set_grid_emf (interface shared with plant.minimal)."""
        self.set_grid_emf(magnitude)

    def load_step(self, mw: float, mvar: float = 0.0) -> None:
        """Add a constant-PQ load of ``mw`` (+ j ``mvar``) at the PCC (cumulative)."""
        self.load_s += complex(mw, mvar) / self.params.grid.s_base_mva
        self._cache = None

    def fault(self, on: bool, z_f: complex = 0.0, **_) -> None:
        """Single-phase-to-ground fault at the PCC (sequence-network equivalent), z_f in network p.u."""
        self.net.set_fault(on, z_f)
        self._refresh()

    def set_scr(self, value: float) -> None:
        self.net.set_scr(value)
        self._refresh()

    def set_sc_connected(self, on: bool) -> None:
        self.net.set_sc_connected(on)
        self._refresh()

    def plug(self, index, on: bool) -> None:
        """Connect/disconnect turbines (their transformer branch); a disconnected converter is blocked."""
        idx = np.atleast_1d(np.asarray(index, dtype=int))
        S = self.layout.turbines(self.X)
        if not on:
            S[T.IF, idx] = 0.0
        self.net.set_plugged(idx, on)
        self._refresh()
        if on:
            _, _, aux = self._eval_cached()
            S[T.IF, idx] = 0.0
            S[T.TH, idx] = np.angle(aux["v"][idx])
            S[T.XI, idx] = 0.0
            self._cache = None
            if np.isin(idx, self.visc_idx).any():  # restart the ViSC law from the new operating point
                _, _, aux = self._eval_cached()
                self._init_law(self.visc_idx, S, aux["v"])
                self._cache = None

    def _refresh(self) -> None:
        self.net.ensure()
        self._cache = None
        self._v_nodes_k = -1  # the network changed: the saved node voltages are not this state's
