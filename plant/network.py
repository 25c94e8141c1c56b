"""Quasi-static positive-sequence network of the wind farm, p.u. on the network base.

The nodes after the turbine terminals and the collector's elements are the layout's
(``PlantParams.topology``, :data:`plant.collectors.COLLECTORS`). Nodes (``topology="farm"``, N
turbines, C clusters)::

    0 .. N-1        turbine LV terminals (0.69 kV; filter capacitor cf as a shunt)
    N .. N+C-1      cluster 66 kV nodes (each cluster's strings aggregated into one pi-section)
    os_mv           offshore substation 66 kV bus
    os_hv           offshore substation 220 kV bus (export cable sending end)
    cable nodes     export_sections-1 internal nodes of the pi-section export cable
    on_hv           onshore 220 kV bus (cable receiving end, shunt reactor)
    pcc             onshore point of common coupling (grid Thevenin, SC step-up, load, fault)
    sc              synchronous-condenser terminal (behind its step-up transformer)

``topology="single"``: node 0 turbine terminal, node 1 pcc (turbine transformer between them),
node 2 sc.

Sources enter as Norton equivalents: converters inject their filter current (a pure current
source, nothing in Y); the grid is E_g behind Z_g (Y_g on the pcc diagonal, E_g Y_g injected);
the condenser is E'' behind (ra + j x'') (admittance on the sc diagonal, E'' Y'' injected).

Y is factorised with a dense LU (``scipy.linalg.lu_factor``) and the explicit inverse is formed
from the factors once, so every solve is one matrix-vector product. Y changes only by
``set_scr``, ``set_plugged``, ``set_fault`` and ``set_sc_connected`` (counted in
``n_factorizations``); the factorisation of every state entered is kept (:data:`FACTOR_CACHE_SIZE`),
so a state entered again — a fault cleared, an SCR restored — or prepared ahead with
:meth:`Network.prepare` costs a lookup, not an LU in the middle of a paced step.

Single-phase-to-ground fault (sequence-network method): the positive-sequence network sees the
fault as a shunt impedance Z_f1 = Z2 + Z0 + 3 Z_f at the fault node, where Z2 and Z0 are the
negative- and zero-sequence Thevenin impedances at that node. Z2 = [Y^-1]_pcc,pcc of the
fault-free positive-sequence Y (passive elements are symmetrical, x2 of the condenser = x''d,
the grid's Z2 = Z1; grid-following converters inject no negative-sequence current, i.e. they
are open circuits in the negative-sequence network). Z0 = k0 Z_g || Z_ontr || Z_sctr: both
transformers are YNd with the grounded star on the pcc side, so the farm side and the condenser
are cut off from the zero-sequence network; a step-up is in Z0 only while its side is in service
(the SC's while it is connected, an onshore unit's while plugged: a YNd transformer switched out
with its machine grounds nothing). Two-phase-to-ground fault (``fault_kind="llg"``, phases b and
c): the shunt is Z2 || (Z0 + 3 Z_f). The positive-sequence voltages and currents are exact for
this equivalent; :meth:`Network.fault_sequences` gives V2 and V0, from which the phase voltages
follow (V_a = V1 + V2 + V0, ...); sub-cycle peaks and DC offsets are not modelled.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from plant.collectors import collector_layout
from plant.dynamic_network import GRID_SOURCE, GROUND, SC_SOURCE, Companion, Elements, History
from plant.params import PlantParams
from sdvisc.vocabulary import OMEGA0


def _par(*zs: complex) -> complex:
    return 1.0 / sum(1.0 / z for z in zs)


def phase_phasors(v1, v2, v0):
    """Phase voltages (a, b, c) on the last axis from the sequence ones: V_a = V1 + V2 + V0,
    V_b = a² V1 + a V2 + V0, V_c = a V1 + a² V2 + V0 (a = e^{j 2π/3})."""
    a = np.exp(2j * np.pi / 3.0)
    rot = np.array([1.0, a * a, a])
    return np.multiply.outer(v1, rot) + np.multiply.outer(v2, rot.conj()) + np.multiply.outer(v0, np.ones(3))


NETWORK_MODELS = ("quasi_static", "dynamic_phasor")
FAULT_KINDS = ("slg", "llg")  # single-phase-to-ground (phase a), two-phase-to-ground (phases b and c)

FACTOR_CACHE_SIZE = 16
"""Network states whose factorisation is kept (each ~(nodes)^2 complex: ~0.2 MB on the farm)."""


class Network:
    """Admittance matrix, its factorisation and the solve V = Y^-1 I."""

    def __init__(self, params: PlantParams, n_turbines: int, step_s: float | None = None):
        self.p = params
        if params.network_model not in NETWORK_MODELS:
            raise ValueError(f"network_model must be one of {NETWORK_MODELS}, got {params.network_model!r}")
        self.dynamic = params.network_model == "dynamic_phasor"
        if self.dynamic and not step_s:
            raise ValueError("the dynamic-phasor network needs the plant's step (step_s)")
        self.h = step_s  # the companion model's step (dynamic-phasor network)
        self.hist: History | None = None  # its history (start_history)
        self.w_full = self.w_red = None  # what the history adds to every node / the reduced voltages
        g = params.grid
        self.n = n_turbines
        self.sb = g.s_base_mva
        self.n_farm = n_turbines - params.onshore_units  # the farm's turbines; the onshore units follow
        if self.n_farm < 0:
            raise ValueError(f"{params.onshore_units} onshore units but only {n_turbines} converters")
        self.rating_mva = np.full(n_turbines, params.turbine.s_rated_mva)
        self.rating_mva[self.n_farm:] = params.onshore_unit_mva
        self.k_t = self.rating_mva / self.sb  # per converter: its own base -> network base (power/current)
        self.k_sc = params.condenser.s_rated_mva / self.sb
        self.plugged = np.ones(n_turbines, dtype=bool)
        self.scr = g.scr
        self.fault_on = False
        self.z_f = 0.0j
        self.fault_kind = "slg"
        self.sc_connected = params.sc_connected
        self.n_factorizations = 0
        self.cache_hits = 0  # factorisations taken from the cache (see factorize)
        self._factor_cache: dict[tuple, dict] = {}
        self.topology = params.topology
        self.collector = collector_layout(params.topology)  # node numbers and the collector's elements
        self.collector.place(self)
        self.n_nodes = self.sc + 1
        self.dirty = True
        self.factorize()

    # ---------------------------------------------------------------- element values
    def z_grid(self) -> complex:
        rx = self.p.grid.r_over_x
        zmag = 1.0 / self.scr
        x = zmag / np.sqrt(1.0 + rx * rx)
        return complex(rx * x, x)

    def z_sc_source(self) -> complex:
        c = self.p.condenser
        return complex(c.ra, c.xd2) / self.k_sc

    def z_sc_tr(self) -> complex:
        return complex(0.0, self.p.condenser.x_tr) / self.k_sc

    def z_onshore_unit(self) -> complex:
        """Series impedance from an onshore unit's terminal to the pcc (network base): its turbine
        transformers in parallel (x_ttr on (S_unit / S_turbine) x s_ttr) and its step-up transformer."""
        g, pp = self.p.grid, self.p
        n_parallel = pp.onshore_unit_mva / pp.turbine.s_rated_mva
        return (complex(g.r_ttr, g.x_ttr) * self.sb / (g.s_ttr_mva * n_parallel)
                + complex(0.0, pp.x_onshore_step_up) * self.sb / pp.onshore_unit_mva)

    def z_ontr(self) -> complex:
        g = self.p.grid
        return complex(g.r_ontr, g.x_ontr) * self.sb / g.s_ontr_mva

    def _cable(self, km: float, r: float, l_mh: float, c_nf: float, v_kv: float):
        zb = v_kv**2 / self.sb
        z = complex(r * km, OMEGA0 * l_mh * 1e-3 * km) / zb
        b = OMEGA0 * c_nf * 1e-9 * km * zb
        return z, b

    # ---------------------------------------------------------------- Y matrix
    def elements(self, with_fault: bool = True) -> Elements:
        """Every passive element of the network in a fixed order: the turbines' filter capacitors,
        their transformers (inactive when unplugged), the array and export cables (pi sections),
        the transformers, the compensation reactors, the grid's Thevenin branch and the SC's step-up."""
        g, t = self.p.grid, self.p.turbine
        el = Elements()
        n = self.n
        for k in range(n):  # filter capacitors (turbine base susceptance cf -> network base)
            el.shunt_c(k, t.cf * float(self.k_t[k]))
        z_ttr = complex(g.r_ttr, g.x_ttr) * self.sb / g.s_ttr_mva
        for k in range(n):
            on = bool(self.plugged[k])
            if k >= self.n_farm:  # onshore unit: its aggregated turbine transformers + its step-up, at the pcc
                el.rl(k, self.pcc, self.z_onshore_unit(), on)
                continue
            el.rl(k, self.collector.turbine_bus(self, k), z_ttr, on)
        self.collector.add_elements(self, el)
        self.grid_element = len(el.a)
        el.rl(self.pcc, GRID_SOURCE, self.z_grid())
        el.rl(self.sc, self.pcc, self.z_sc_tr())
        self.sc_element = len(el.a)
        el.rl(self.sc, SC_SOURCE, self.z_sc_source(), self.sc_connected)
        fault = with_fault and self.fault_on
        el.rl(self.pcc, GROUND, self.z_fault_shunt() if fault else 1.0, fault)
        return el

    def build_y(self, with_fault: bool = True) -> np.ndarray:
        """The quasi-static Y: every element's 1/z or j b (the grid's and the SC's source impedances
        and the fault's sequence shunt among them)."""
        el = self.elements(with_fault)
        comp = Companion(el, self.n_nodes, 1.0)  # (h is not used for Y)
        y = np.zeros((self.n_nodes, self.n_nodes), dtype=complex)
        comp.stamp(y, comp.y_steady)
        if with_fault:
            between = (comp.a < self.n_nodes) & (comp.b < self.n_nodes) & (np.array(el.bsh) == 0.0) \
                & np.array(el.active)
            self.branch_a, self.branch_b = comp.a[between], comp.b[between]
            self.branch_z = np.array(el.z)[between]
            self._elements = el
        return y

    def series_losses(self, v: np.ndarray) -> float:
        """Sum of R |I|^2 over all series branches (network base); shunts are lossless."""
        i = (v[self.branch_a] - v[self.branch_b]) / self.branch_z
        return float(np.sum(self.branch_z.real * np.abs(i) ** 2))

    def z_zero(self) -> complex:
        """Zero-sequence Thevenin impedance at the pcc: the grounded grid (k0 Z_g) in parallel with the
        YNd step-ups whose grounded star faces the pcc and whose side is in service (the onshore
        transformer on the farm; the SC's while connected; each plugged onshore unit's). The delta
        windings cut everything behind them off."""
        zs = [self.p.grid.k0_grid * self.z_grid()]
        if self.sc_connected:
            zs.append(self.z_sc_tr())
        zs += self.collector.zero_sequence(self)  # the farm: the onshore transformer, each plugged unit's step-up
        return _par(*zs)

    def fault_shunt_of(self, z2: complex, z0: complex) -> complex:
        """The fault's positive-sequence shunt from the sequence impedances at the pcc: Z2 + Z0 + 3 Z_f
        (single phase to ground) or Z2 || (Z0 + 3 Z_f) (two phases to ground)."""
        z0f = z0 + 3.0 * self.z_f
        return z2 + z0f if self.fault_kind == "slg" else z2 * z0f / (z2 + z0f)

    def z_fault_shunt(self) -> complex:
        """Positive-sequence shunt of the fault at the pcc (:meth:`fault_shunt_of`)."""
        y0 = self.build_y(with_fault=False)
        e = np.zeros(self.n_nodes, dtype=complex)
        e[self.pcc] = 1.0
        self.z2col = np.linalg.solve(y0, e)  # negative-sequence transfer impedances to the pcc
        z2 = self.z2col[self.pcc]
        self.n_factorizations += 1
        z0 = self.z_zero()
        self.z2, self.z0 = z2, z0
        return self.fault_shunt_of(z2, z0)

    def fault_sequences(self, v1: np.ndarray):
        """Sequence quantities during the fault from the solved positive-sequence voltages v1.

        Returns (i_f, v2, v0_pcc): the positive-sequence fault current I1 = V1/Z_shunt leaving the
        network at the pcc, the negative-sequence node voltages v2 = -z2col I2 and the pcc's
        zero-sequence voltage -Z0 I0, with I2 = I0 = I1 (single phase) or I2 = -V1/Z2,
        I0 = -V1/(Z0 + 3 Z_f) (two phases: V1 = V2 at the fault, I1 + I2 + I0 = 0).
        """
        if not self.fault_on:
            return 0.0j, np.zeros_like(v1), 0.0j
        v_f = v1[self.pcc]
        i1 = v_f / self.fault_shunt_of(self.z2, self.z0)
        if self.fault_kind == "slg":
            i2 = i0 = i1
        else:
            i2, i0 = -v_f / self.z2, -v_f / (self.z0 + 3.0 * self.z_f)
        return i1, -self.z2col * i2, -self.z0 * i0

    # ---------------------------------------------------------------- factorisation
    def factorize(self) -> None:
        """Make the present network state's solve current: from the cache when this state was
        factorised before (a fault cleared, an SCR restored, a state prepared by :meth:`prepare`),
        else computed (:meth:`_compute`). Counts one change either way (``n_factorizations``)."""
        key = self._state_key()
        was_active = None if self.hist is None else self.comp.g != 0.0
        found = self._factor_cache.get(key)
        if found is None:
            self._compute()
            found = {name: getattr(self, name) for name in self._FACTOR_ATTRS if hasattr(self, name)}
            if len(self._factor_cache) >= FACTOR_CACHE_SIZE:
                self._factor_cache.pop(next(iter(self._factor_cache)))
            self._factor_cache[key] = found
        else:
            self.cache_hits += 1
            for name, value in found.items():
                setattr(self, name, value)
        self.n_factorizations += 1
        self.dirty = False
        if self.hist is not None:
            self.hist.switch(was_active, self.comp)  # elements switched in or out
            self.hist.refresh(self.comp)  # currents kept, η with the present coefficients
            self._history_offsets()

    def prepare(self, **state) -> None:
        """Factorise a state the run will enter (e.g. ``fault_on=True`` before a scheduled fault)
        ahead of time, so entering it costs a cache lookup instead of a factorisation in the middle
        of a paced step; the present state is left as it was."""
        saved = {name: getattr(self, name) for name in state}
        current = (self._state_key(), self.dirty)
        for name, value in state.items():
            setattr(self, name, value)
        if self._state_key() not in self._factor_cache:
            present = {name: getattr(self, name) for name in self._FACTOR_ATTRS if hasattr(self, name)}
            self.factorize()
            self.n_factorizations -= 1  # nothing changed for the model
            for name, value in present.items():
                setattr(self, name, value)
        for name, value in saved.items():
            setattr(self, name, value)
        assert (self._state_key(), self.dirty) == current

    _FACTOR_ATTRS = ("y", "lu", "zinv", "y_grid", "y_sc", "red_idx", "zcols", "zred", "all_plugged",
                     "branch_a", "branch_b", "branch_z", "z2col", "z2", "z0", "comp", "zsolve", "y_grid_u", "y_sc_u",
                     "_elements")

    def _state_key(self) -> tuple:
        return (self.scr, self.fault_on, self.z_f, self.fault_kind, self.sc_connected, self.plugged.tobytes())

    def _compute(self) -> None:
        self.y = self.build_y()
        self.lu = sla.lu_factor(self.y)
        self.zinv = sla.lu_solve(self.lu, np.eye(self.n_nodes, dtype=complex))
        self.y_grid = 1.0 / self.z_grid()
        self.y_sc = 1.0 / self.z_sc_source() if self.sc_connected else 0.0
        if self.dynamic:  # the dynamics solve G v = u - A^T eta (plant/dynamic_network.py)
            self.comp = Companion(self._elements, self.n_nodes, self.h)
            gmat = np.zeros_like(self.y)
            self.comp.stamp(gmat, self.comp.g)
            self.zsolve = np.linalg.inv(gmat)
            # the sources enter through their branches' companion conductances
            self.y_grid_u, self.y_sc_u = self.comp.g_of(self.grid_element), self.comp.g_of(self.sc_element)
        else:
            self.zsolve, self.y_grid_u, self.y_sc_u = self.zinv, self.y_grid, self.y_sc
        # Reduced solve used every step: only the turbine terminals, the pcc and the sc node carry
        # injections and only their voltages are needed by the dynamics, so
        #   [v_turbines, V_pcc, V_sc] = zred @ u,  u = [i_turb (turbine base), E_g Y_g - I_load, E'' Y''],
        # with the turbine-base scaling and the plugged mask folded into the columns (one (N+2)^2
        # complex mat-vec). zcols @ u gives every node voltage (outputs only). With the dynamic-phasor
        # network both add the history's share (w_red, w_full).
        self.red_idx = np.r_[np.arange(self.n), self.pcc, self.sc]
        scale = np.r_[self.k_t * self.plugged, 1.0, 1.0]
        self.zcols = np.ascontiguousarray(self.zsolve[:, self.red_idx] * scale)
        self.zred = np.ascontiguousarray(self.zcols[self.red_idx])
        self.all_plugged = bool(self.plugged.all())

    # ---------------------------------------------------------------- dynamic-phasor history
    def start_history(self, v_nodes: np.ndarray, e_grid: complex, e_sc: complex) -> None:
        """The dynamic-phasor network in steady state at the node voltages ``v_nodes`` (no-op when
        quasi-static)."""
        if not self.dynamic:
            return
        self.ensure()
        self.hist = History(len(self.comp.g))
        self.hist.start(self.comp, v_nodes, e_grid, e_sc)
        self._history_offsets()

    def advance_history(self, v_nodes: np.ndarray, e_grid: complex, e_sc: complex) -> None:
        """One plant step on, from the node voltages of the step's first stage."""
        self.hist.advance(self.comp, v_nodes, e_grid, e_sc)
        self._history_offsets()

    def _history_offsets(self) -> None:
        self.w_full = self.zsolve @ self.hist.node_injection(self.comp)
        self.w_red = self.w_full[self.red_idx]

    def grid_current(self, v_pcc: complex, e_grid: complex) -> complex:
        """Current from the grid source into the pcc at the pcc voltage ``v_pcc`` of this step."""
        if self.hist is None:
            return (e_grid - v_pcc) * self.y_grid
        return -self.hist.current(self.comp, self.grid_element, v_pcc - e_grid)

    def sc_current_last(self) -> complex:
        return -complex(self.hist.i[self.sc_element])  # the SC's stator current (network base), last step

    def sc_current(self, v_sc: complex, e_sc: complex) -> complex | None:
        """The condenser's stator current (network base) with the dynamic-phasor network (the
        current of its subtransient branch); None when quasi-static (the machine's own algebraic
        (E'' - v)/z'')."""
        if self.hist is None:
            return None
        return -self.hist.current(self.comp, self.sc_element, v_sc - e_sc)

    def ensure(self) -> None:
        if self.dirty:
            self.factorize()

    def set_scr(self, scr: float) -> None:
        self.scr = float(scr)
        self.dirty = True

    def set_plugged(self, idx, on: bool) -> None:
        self.plugged[np.atleast_1d(idx)] = bool(on)
        self.dirty = True

    def set_fault(self, on: bool, z_f: complex = 0.0, kind: str = "slg") -> None:
        """Fault at the pcc through z_f (network p.u.), ``kind`` one of FAULT_KINDS."""
        if kind not in FAULT_KINDS:
            raise ValueError(f"fault kind must be one of {FAULT_KINDS}, got {kind!r}")
        self.fault_on = bool(on)
        self.z_f = complex(z_f)
        self.fault_kind = kind
        self.dirty = True

    def set_sc_connected(self, on: bool) -> None:
        self.sc_connected = bool(on)
        self.dirty = True

    # ---------------------------------------------------------------- solve
    def injections(self, i_turb, e_grid: complex, e_sc: complex, i_load: complex) -> np.ndarray:
        """Node current injections (network base) from turbine currents on the turbine base."""
        inj = np.zeros(self.n_nodes, dtype=complex)
        inj[: self.n] = i_turb * self.k_t * self.plugged
        inj[self.pcc] = e_grid * self.y_grid - i_load
        inj[self.sc] = e_sc * self.y_sc
        return inj

    def reduced_u(self, i_turb, e_grid: complex, e_sc: complex, i_load: complex) -> np.ndarray:
        """Source vector u of the reduced solve (see ``factorize``)."""
        u = np.empty(self.n + 2, dtype=complex)
        u[: self.n] = i_turb
        u[self.n] = e_grid * self.y_grid_u - i_load
        u[self.n + 1] = e_sc * self.y_sc_u
        return u

    def solve(self, inj: np.ndarray) -> np.ndarray:
        """V = Y^-1 I with the pre-factorised Y (one mat-vec with the stored inverse)."""
        return self.zinv @ inj

    def solve_lu(self, inj: np.ndarray) -> np.ndarray:
        """Same solve through the LU factors (reference path)."""
        return sla.lu_solve(self.lu, inj)
