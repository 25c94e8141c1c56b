"""The plant: network + turbines + condenser + grid source, fixed-step integration.

Time exists only as ``step counter * step_s``; there is no wall clock here. One call of
``step()`` advances ``step_s`` with ``substeps`` ETD2 (default), Heun (RK2) or RK4 sub-steps on
the whole state (turbines, condenser, grid source, PCC PLL and, for ``hd_visc`` turbines, the ViSC
law state). The network is algebraic and solved at every stage with one reduced mat-vec of the
pre-inverted Y (network.py). The slow mechanical terms are held over ``slow_every`` steps
(docs/plant.md, Integration).

Where things are: the steady state before t = 0 in steady_state.py, the state layout in layout.py, the right-hand side in equations.py (compiled
kernels in kernels.py through compiled.py where they apply, else the general numpy path), the one
ETD2 update in integrator.py, the commands and events in commands.py.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from plant import turbine as T
from plant.commands import Commands
from plant.compiled import CompiledPath
from plant.condenser import DELTA, EFD, OMEGA, Condenser
from plant.equations import RightHandSide
from plant.integrator import Etd2Coefficients, correct, predict, rk4_step
from plant.layout import GRID_SPEED, StateLayout
from plant.network import Network
from plant.params import PlantParams
from plant.slots import operating_values
from plant.steady_state import SteadyState
from plant.wpp import WppController
from sdvisc.vocabulary import F_NOMINAL_HZ, OMEGA0


class Plant(Commands, RightHandSide, SteadyState):
    """Software stand-in for the RTDS wind-farm model (see docs/plant.md)."""

    def __init__(self, params: PlantParams | None = None, n_turbines: int = 50, step_s: float = 0.67e-3,
                 substeps: int = 1, method: str = "etd2", slow_every: int = 10, jit: bool = True):
        self.params = params or PlantParams()
        self.n = n = int(n_turbines) + int(self.params.onshore_units)  # the farm's turbines, then the onshore units
        self.step_s = float(step_s)
        self.substeps = int(substeps)
        if method not in ("etd2", "rk2", "rk4"):
            raise ValueError("method must be 'etd2', 'rk2' or 'rk4'")
        self.method = method
        self.k = 0
        self.net = Network(self.params, n, self.step_s)
        if self.net.dynamic and (self.substeps != 1 or method == "rk4"):
            raise ValueError("the dynamic-phasor network advances once per plant step: substeps 1, etd2 or rk2")
        jit = jit and not self.net.dynamic  # the compiled kernels solve the quasi-static network only
        self.tb = T.TurbineBank(self.params.turbine, n, self.params.v_wind, self.params.battery,
                                rating_mva=self.net.rating_mva)
        self.sc = Condenser(self.params.condenser)
        self.layout = StateLayout(n)
        self.size = self.layout.size
        self.load_s = 0.0j
        self.visc_idx = np.array([], dtype=int)  # hd_visc turbines
        self.xl = None  # their law states (sdc_unit.law), None without hd_visc turbines
        self.visc_params = self.params.visc_params
        self._cache = None  # (dX, dxl, aux) of the present state
        self._coef = {}  # ETD2 coefficients by step length and mode/network key
        self._mode_key = None
        self._compiled = CompiledPath(self.params.turbine, self.layout, self.tb.batt) if jit else None  # jit=False: numpy only
        self.compiled_law = True  # False: the hd_visc law in numpy between compiled kernels (a test's reference)
        self.fuse_first_stage = True  # False: a stale first stage evaluated in a call of its own (a test's reference)
        self._law_c = None  # (ViscParams, count, law.param_rows) for the compiled law
        self._any_battery = False  # any turbine's battery connected (kept by set_battery: not an array scan per step)
        self.slow_every = max(1, int(slow_every))
        self._slow_keep = False
        self._slow_next = 0
        # the plant's voltage controller at the PCC (the farm only: "single" is one turbine on a bus)
        self.wpp = WppController(self.params.wpp) if self.params.wpp.enabled and self.params.topology == "farm" else None
        self._wpp_mask = np.arange(n) < self.net.n_farm  # it orders the farm's turbines, not onshore units
        self._init_steady_state()

    # ================================================================== initialisation (plant/steady_state.py)
    def reinitialise(self) -> None:
        """Recompute the steady state for the present P*/Q* (all turbines grid-following, t kept)."""
        self.tb.mode[:] = T.GFL
        self.visc_idx = np.array([], dtype=int)
        self.xl = None
        self.net.ensure()
        self._init_steady_state()

    # ================================================================== integration
    def _eval_cached(self):
        """(dX, dxl, aux) of the present state, evaluated once (the first stage of the next step)."""
        if self._cache is None:
            self._hold_slow_if_due()
            self._cache = self._evaluate(self.X, self.xl, want_aux=True)
        return self._cache

    def _hold_slow_if_due(self) -> None:
        """Before an evaluation of the present state: the slow terms are re-evaluated every
        ``slow_every`` steps and after any command/event."""
        scheduled = self.tb.slow is None or self.k >= self._slow_next
        if not self._slow_keep or scheduled:
            if scheduled and self.wpp is not None:  # the plant's voltage controller: a sampled controller on
                # the steps k = 0, slow_every, 2 slow_every, ... whatever commands come between
                # (its own cycle inside; the turbines' Q limitation at their measured terminal voltages)
                v_wt = self.layout.turbines(self.X)[T.VM].real[self._wpp_mask]
                self.tb.q_wpp[self._wpp_mask] = self.wpp.update(self.t, abs(self._v_pcc_last), v_wt)
            self._hold_slow(after_command=not self._slow_keep)
            self._slow_next = (self.k // self.slow_every + 1) * self.slow_every
        self._slow_keep = False

    def _hold_slow(self, after_command: bool) -> None:
        """Evaluate and hold the slow terms; after a command (or at the start) also hand the
        compiled path the operating values (grid, condenser, load, AVR) the command may have changed."""
        if self._compiled is None:
            self.tb.hold_slow(self.layout.turbines(self.X))
            return
        self.tb.slow = self._compiled.hold_slow(self.X, self.tb)
        if after_command:
            self._compiled.set_values(operating_values(self.params, self.net, self.sc, self.load_s, self.pm0))

    def step(self, remote_inputs=None) -> None:
        """Advance one step of ``step_s``. ``remote_inputs``: (index_array, v_ref_d, v_ref_q) or None."""
        if remote_inputs is not None:
            self.apply_remote(*remote_inputs)
        self._check_fallback()
        self.net.ensure()
        if self._cache is None and self.fuse_first_stage and self._compiled is not None and self.xl is None \
                and not self._any_battery and self.substeps == 1 and self.method != "rk4":
            # the first stage is stale (new remote references, a command): evaluated in the step's call
            self._hold_slow_if_due()
            if self._compiled.covers(self.tb, self.net):
                x_next, evaluation, self._v_pcc_last = self._compiled.step_evaluating_first_stage(
                    self.X, self._coefficients(self.step_s), self.tb, self._v_pcc_last, self.k + 1 < self._slow_next)
                self._advance(None, x_next, None, evaluation)
                return
            self._cache = self._evaluate(self.X, self.xl, want_aux=True)
        k1, l1, aux = self._eval_cached()
        if self.net.dynamic:  # the network's history moves to this step's voltages (dynamic_network.py)
            self.net.advance_history(self._full_v(aux), aux["e_grid"], aux["e_sc"])
        self._v_pcc_last = aux["v_pcc"]
        counted = self._battery_after_step(aux)
        X, xl = self.X, self.xl
        if self.substeps > 1 or self.method == "rk4":
            self._advance(counted, *self._substeps(X, xl, k1, l1))
            return
        coef = self._coefficients(self.step_s)
        compiled = self._compiled
        if compiled is not None and compiled.covers(self.tb, self.net) and (xl is None or self.compiled_law):
            law = None if xl is None else (xl, l1, self._coefficients(self.step_s, xl.size), *self._law_arrays())
            soc_next = self.tb.batt.soc if counted is None else counted[0]
            # the usual case: (X+, xl+, (dX+, aux+) or None, dxl+)
            self._advance(counted, *compiled.step(X, k1, coef, self.tb, soc_next, self._v_pcc_last,
                                                  self.k + 1 < self._slow_next, law))
            return
        self._advance(counted, *self._etd2(X, xl, k1, l1, coef, self.step_s))

    def _battery_after_step(self, aux):
        """The batteries' (SOC, energy) after this step, counted at the current of its first stage
        ``aux`` (plant/battery.py), or None without batteries. The step itself holds the SOC of
        its start; the state it reaches is evaluated at this SOC (the next step's)."""
        if not self._any_battery:
            return None
        i = aux["ibatt"] if self.net.all_plugged else np.where(self.net.plugged, aux["ibatt"], 0.0)
        return self.tb.batt.after_step(i, aux["vdc"], self.step_s)

    def _substeps(self, X, xl, k1, l1):
        """``substeps`` steps of step_s/substeps (ETD2, or RK4 with method "rk4")."""
        h = self.step_s / self.substeps
        for s in range(self.substeps):
            if s:
                k1, l1, aux = self._evaluate(X, xl, want_aux=True)
                self._v_pcc_last = aux["v_pcc"]
            if self.method == "rk4":
                X, xl = rk4_step(self._derivatives, X, xl, k1, l1, h)
            else:
                X, xl = self._etd2(X, xl, k1, l1, self._coefficients(h), h)
        return X, xl

    def _etd2(self, X, xl, k1, l1, coef, h):
        """One ETD2 step of the plant state (coefficients ``coef``) and of the law state (c = 0)."""
        a = predict(X, k1, coef)
        xa = None
        if xl is not None:
            law_coef = self._coefficients(h, law_size=xl.size)
            xa = predict(xl, l1, law_coef)
        k2, l2, _ = self._evaluate(a, xa)
        X = correct(a, k1, k2, coef)
        if xl is not None:
            xl = correct(xa, l1, l2, law_coef)
        return X, xl

    def _derivatives(self, X, xl):
        return self._evaluate(X, xl)[:2]

    def _advance(self, counted, X, xl, evaluation=None, dxl=None) -> None:
        """Store the new state and the batteries' ``counted`` (SOC, energy) (``_battery_after_step``),
        count the step and evaluate it (the next step's first stage) unless ``evaluation`` = (dX, aux)
        of it is given (the compiled step)."""
        if counted is not None:
            self.tb.batt.soc, self.tb.batt.energy = counted
        self.X, self.xl = X, xl
        self.k += 1
        if evaluation is not None:
            self._cache = (evaluation[0], dxl, evaluation[1])  # dxl: the law derivatives of the compiled step
            self._slow_keep = False
            self._v_pcc_last = evaluation[1]["v_pcc"]
            return
        self._cache = None
        self._slow_keep = True  # only the step itself may keep the held slow terms
        self._v_pcc_last = self._eval_cached()[2]["v_pcc"]

    def _coefficients(self, h: float, law_size: int | None = None) -> Etd2Coefficients:
        """ETD2 coefficients (integrator.py) for step h: c = OMEGA0 kpc / lf on the filter current of
        plugged turbines with a local current loop (grid-following, and remote with remote_apply =
        "i_ref"; the closed current loop is di/dt = -c (i - i*) + ...), c = 1/(tau_dc r_b) on the
        DC link w of plugged turbines with a battery (its pole, plant/battery.py), c = 0 elsewhere
        (-> Heun), and everywhere with method "rk2" or for the law states (``law_size``)."""
        if law_size is not None:
            key = (h, "law", law_size)
        else:
            self._mode_info()  # refreshes self._mode_key; every change of `plugged` refactorises the network
            key = (h, self._mode_key, self.net.n_factorizations, self.params.turbine.remote_apply,
                   self.tb.battery.tobytes())
        coef = self._coef.get(key)
        if coef is not None:
            return coef
        if len(self._coef) > 64:
            self._coef.clear()
        c = np.zeros(self.size if law_size is None else law_size)
        if law_size is None and self.method == "etd2":
            tp = self.params.turbine
            loop = self.tb.mode == T.GFL
            if tp.remote_apply == "i_ref":
                loop = loop | (self.tb.mode == T.REMOTE)
            c[: self.n] = np.where(loop & self.net.plugged, OMEGA0 * tp.kpc / tp.lf, 0.0)
            c[T.W * self.n:(T.W + 1) * self.n] = np.where(self.tb.battery & self.net.plugged,
                                                           self.tb.batt.dc_link_pole(tp.tau_dc), 0.0)
        coef = self._coef[key] = Etd2Coefficients(c, h, complex_state=law_size is None)
        return coef

    @property
    def t(self) -> float:
        return self.k * self.step_s

    # ================================================================== measurement / outputs
    def measurements(self) -> dict:
        """Per-turbine measurement arrays (turbine p.u.): v_d, v_q, i_d, i_q, p, q, v_dc, omega_meas."""
        _, _, aux = self._eval_cached()
        m = aux.get("meas")
        if m is None:  # general path: built from its results
            v, i = aux["v"], aux["i"]
            s = v * i.conj()
            om = aux["ev"] * self.params.turbine.kp_pll
            om += self.X[T.XP * self.n:(T.XP + 1) * self.n].real
            om += 1.0
            m = aux["meas"] = {"v_d": v.real, "v_q": v.imag, "i_d": i.real, "i_q": i.imag, "p": s.real,
                               "q": s.imag, "v_dc": aux["vdc"], "omega_meas": om}
        return dict(m)

    def recorded(self) -> dict:
        """What ``timeseries.csv`` holds (plant.service.recorder): ``t``, ``v_pcc``, ``f_pcc_hz`` and per
        turbine ``p``, ``q``, ``i_mag``, ``mode``, ``soc``, ``p_batt`` (units as in :meth:`outputs`, which
        includes these), from the present evaluation only: no full node-voltage solve, no fault
        sequences (benchmarks/plant_speed.py ``recorder_50wt_4remote``: its cost against outputs())."""
        _, _, aux = self._eval_cached()
        s_wt, i = aux["v"] * np.conj(aux["i"]), aux["i"]
        p_batt = aux["pbatt"]
        return {"t": self.t, "v_pcc": abs(aux["v_pcc"]), "f_pcc_hz": F_NOMINAL_HZ * float(aux["f_pcc_pu"]),
                "p": s_wt.real, "q": s_wt.imag, "i_mag": np.abs(i), "mode": self.tb.mode.copy(),
                "soc": self.tb.batt.soc.copy(),
                "p_batt": np.where(self.net.plugged, p_batt, 0.0) if np.ndim(p_batt) else np.zeros(self.n)}

    def outputs(self) -> dict:
        """Scalar and per-turbine quantities for time series (see docs/plant.md for units): those of
        :meth:`recorded` and the rest."""
        rec = self.recorded()
        _, _, aux = self._eval_cached()
        net, n, lay = self.net, self.n, self.layout
        S = lay.turbines(self.X)
        V = self._full_v(aux)
        i_sc = aux["i_sc"]
        s_sc = V[net.sc] * np.conj(i_sc)
        ig = net.grid_current(V[net.pcc], aux["e_grid"])  # from the source into the pcc
        s_grid = -V[net.pcc] * np.conj(ig)  # flowing pcc -> grid
        xsc = self.X[lay.condenser:lay.grid].real
        # phase quantities during the single-phase fault (sequence networks; see network.py)
        i_f, v2, v0 = net.fault_sequences(V)
        a = np.exp(2j * np.pi / 3.0)
        rot = np.array([1.0, a * a, a])  # phases a, b, c of the positive sequence
        v_ph = np.abs(V[net.pcc] * rot + v2[net.pcc] * rot.conj() + v0)
        # condenser: negative-sequence current -V2/(ra + j x''); YNd1 step-up shifts I1 by -30 deg and
        # I2 by +30 deg on the machine side; no zero sequence reaches the machine
        i2_sc = -v2[net.sc] / self.sc.z2 if net.sc_connected else 0.0j
        sh = np.exp(-1j * np.pi / 6.0)
        i_sc_ph = np.abs(i_sc * sh * rot + i2_sc * sh.conjugate() * rot.conj())
        visc_delta = np.full(n, np.nan)
        visc_e = np.full(n, np.nan)
        lo = aux["law_out"]
        if lo is not None:
            visc_delta[self.visc_idx] = lo.delta
            visc_e[self.visc_idx] = lo.e_mag
        return {
            **rec,
            "v_os": abs(V[net.os_mv]),
            "v_sc": abs(V[net.sc]), "f_grid": float(self.X[lay.grid + GRID_SPEED].real),
            "p_grid": s_grid.real, "q_grid": s_grid.imag,
            "p_wt": rec["p"], "q_wt": rec["q"], "i_wt": rec["i_mag"], "v_wt": np.abs(aux["v"]),
            "p_sc": s_sc.real, "q_sc": s_sc.imag, "i_sc": abs(i_sc),
            "sc_delta": xsc[DELTA], "sc_omega": xsc[OMEGA],
            "sc_e": abs(aux["e_sc"]) if net.sc_connected else 0.0, "sc_efd": xsc[EFD],
            "visc_delta": visc_delta, "visc_e": visc_e,
            "v_dc": aux["vdc"], "pitch": S[T.B].real.copy(), "omega_r": S[T.WR].real.copy(),
            "v_pcc_ph": v_ph, "i_sc_ph_max": float(np.max(i_sc_ph)), "i_fault": abs(i_f),
            "p_me": aux["pme"], "losses": net.series_losses(V),
            "e_batt_mwh": self.tb.batt.energy_mwh(),
        }

    # ================================================================== offline runs
    def run_offline(self, t_end: float, events: list[tuple[float, Callable]] | None = None,
                    record_every: int = 1) -> dict:
        """Run until t_end (s) as fast as possible; events [(t, callable(plant))]; returns arrays."""
        ev = sorted(events or [], key=lambda e: e[0])
        j = 0
        rec: dict[str, list] = {}
        n_steps = int(round(t_end / self.step_s))
        while self.k < n_steps:
            while j < len(ev) and ev[j][0] <= self.t + 0.5 * self.step_s:
                ev[j][1](self)
                j += 1
            if self.k % record_every == 0:
                for key, val in self.outputs().items():
                    rec.setdefault(key, []).append(val)
            self.step()
        return {k: np.array(v) for k, v in rec.items()}

    # ================================================================== for reference solvers
    def rhs_real(self, _t, y):
        """Real flat right-hand side (plant state + law state) for scipy.integrate.solve_ivp.

        The general path's equations, with the slow mechanical terms evaluated at every call.
        """
        if self.net.dynamic:
            raise ValueError("rhs_real: the dynamic-phasor network is stepped, not a right-hand side")
        self.tb.slow = None
        X = y[: self.size] + 1j * y[self.size:2 * self.size]
        xl = None if self.xl is None else y[2 * self.size:].reshape(np.shape(self.xl))
        dX, dxl, aux = self._evaluate(X, xl, want_aux=True)
        self._v_pcc_last = aux["v_pcc"]
        parts = [dX.real, dX.imag]
        if dxl is not None:
            parts.append(np.ravel(dxl))
        return np.concatenate(parts)

    def state_real(self):
        parts = [self.X.real, self.X.imag]
        if self.xl is not None:
            parts.append(np.ravel(self.xl))
        return np.concatenate(parts)

    def set_state_real(self, y) -> None:
        self.X = y[: self.size] + 1j * y[self.size:2 * self.size]
        if self.xl is not None:
            self.xl = y[2 * self.size:].reshape(np.shape(self.xl))
        self._cache = None
