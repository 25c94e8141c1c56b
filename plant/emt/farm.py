"""F8's farm arrangement in EMT: N SDViSC turbines (each its own average-model converter with the ViSC law
and its droop m_q) behind their turbine transformers and their cluster's array cable, the rest of the farm
aggregated into one current source — a constant-P injection at the offshore collector (``injection``) or one
grid-following converter with the phasor turbine's controls behind the aggregated turbine transformers and
array cables (``gfl``, plant/emt/gfl_farm.py) — the export path (offshore
transformer, export cable, onshore transformer) to the PCC, the grid's Thevenin source, a fault switch at
the PCC; optionally the 40 MVA SC at the PCC (its E'' behind x''_d driven by the project's condenser model,
as plant/emt/arrangement.py).

Element values are the phasor plant's (plant/network.py on the same ``PlantParams``); the operating point
is the phasor plant's F8 set-up (plant.cases.visc_plant, the SDViSC turbines at P = 0 before activation)
at the PCC: the grid EMF and the current the onshore transformer delivers, so the PCC starts at the same
voltage; the EMT circuit's own load flow (plant/emt/netlist.py) then gives every node. The export cable is
one pi section (the phasor plant: ``export_sections``) with its compensation reactors at both ends; the
array cables' charging sits at the collector. Left out (stated in docs/plant.md, "EMT backend"): the other
clusters' array cables and turbine transformers one by one (``injection``: none, the farm injects at the
collector; ``gfl``: one equivalent of each), the other turbines' currents in the SDViSCs' array cable. The
stepped run, with the exchange every circuit step or every Ts: plant/emt/farm_run.py.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np

import plant.cases
from plant.condenser import Condenser
from plant.emt import arrangement, frame, netlist
from plant.emt.devices import CondenserEmf, FarmInjection, ViscConverter
from plant.emt.farm_run import EXCHANGES, run_farm, sdc_measurements
from plant.emt.gfl_farm import GflAggregate
from plant.emt.model import STEPS_PER_TS, TS_S
from sdc_unit import law
from sdc_unit.discrete import DiscreteVisc
from sdc_unit.params import ViscParams

FARM_MODELS = ("injection", "gfl")
LOAD_FLOW_ITERATIONS = 4  # the farm's injection matched to the PCC's current (converges to 1e-9 in 3)
K_AD_PARALLEL = 0.5
"""The SDViSC converters' active damping gain here (``TurbineParams.k_ad`` is 0.2) [measured: with 0.2 the
four average converters in parallel on this circuit have a growing ~125 Hz mode (the PCC's V1 peak to peak
0.0004 p.u. over 0.5-1 s, 0.0055 over 1-2 s, a loss of stability by 2-2.5 s; 0.4 p.u. with 0), with 0.5
it is at rest (< 1e-6 p.u.); one unit in the comparison arrangement is at rest with 0.2]. Active damping
acts on v - its low-pass (w_ad), so the steady state (the droop's Q) does not depend on it. For the exchange
every step the damping is applied from Python with the last step's v; with the exchange every Ts it is
inside the circuit (farm_run) and with the phasor turbine's 0.2 the four are at rest at F8's grid (V1 peak
to peak 4e-10 p.u. over 2-2.5 s, against 0.02 every step; an ad-hoc probe, 2026-12-06) but not in F7's
weak grid: at SCR 1.69 after the step (the phasor plant's boundary + 0.1) their terminals reach 3.9 p.u.,
with 0.5 the farm is stable there (tests/unit/test_emt_gfl.py's F7 test). Both exchanges use 0.5."""


@dataclass
class FarmCircuit:
    net: netlist.Netlist
    v0: dict
    n_visc: int
    k_unit: float  # a turbine's rating / network base
    z_filter: complex  # network base
    i_unit0: np.ndarray  # converter currents at the start (network base, out of the converter)
    visc_params: list
    farm_s: complex  # the aggregated farm's injection (network base) at its node
    farm_rating: float
    sc_state: np.ndarray | None = None
    sc_v_ref: float = 1.0
    farm_model: str = "injection"
    farm_i0: complex = 0j  # the aggregated farm's current at the start (network base)
    k_agg: float = 0.0  # the aggregated turbines' rating on the network base ("gfl")


def phasor_farm_plant(n_visc: int, m_q=None, with_sc: bool = False, visc_params: ViscParams | None = None,
                      **grid):
    """The phasor plant of F8's set-up: ``n_visc`` SDViSC turbines (cluster 3) at P = 0 not yet active,
    with ``visc_params`` (default ViscParams()) and droops ``m_q`` (one per unit; None: the params');
    ``with_sc``: the SC in service as well (F7's SC case, the benchmark's arrangement)."""
    vp = visc_params or ViscParams()
    if m_q is not None and n_visc:
        vp = vp.with_changes(m_q=np.asarray(m_q, dtype=float)[:n_visc])
    if not with_sc:
        return plant.cases.visc_plant(n_visc, vp, activate=False, **grid)
    p = plant.cases.sc_plant(**grid)
    p.visc_params = vp
    idx = plant.cases.visc_indices(n_visc)
    p.set_power_ref(idx, p=0.0)
    p.reinitialise()
    return p


def build_case(n_visc: int, m_q=None, with_sc: bool = False, r_fault: float = arrangement.R_FAULT,
               scr_after: float | None = None, visc_params: ViscParams | None = None,
               farm_model: str = "injection", damping_k: float = 0.0, fault_kind: str = "slg",
               **grid) -> tuple[FarmCircuit, object]:
    """(the EMT circuit of F8's arrangement and its load flow, the phasor plant it came from); ``r_fault``:
    the fault's resistance per phase when closed (p.u., network base), on phase a (``fault_kind`` "slg") or
    all three to ground ("3ph"); ``scr_after``: the grid's Thevenin
    impedance is that of this SCR with a parallel branch (the same X/R) that makes it the phasor plant's
    SCR until its breaker opens (:meth:`EmtFarm.scr_step`); ``farm_model``: the rest of the farm as a
    current source at the collector (``injection``, devices.FarmInjection) or as one grid-following
    converter behind the aggregated turbine transformers and array cables (``gfl``, gfl_farm.GflAggregate:
    node ``wt`` with the turbines' filter capacitors, ``wcl`` the clusters' equivalent node); ``damping_k``:
    the SDViSCs' active damping inside the circuit (their filters divided by 1 + k, farm_run's ``ts``)."""
    if fault_kind not in ("slg", "3ph"):
        raise ValueError(f"fault_kind {fault_kind!r}: 'slg' or '3ph'")
    if farm_model not in FARM_MODELS:
        raise ValueError(f"farm_model {farm_model!r}: one of {', '.join(FARM_MODELS)}")
    p = phasor_farm_plant(n_visc, m_q, with_sc, visc_params, **grid)
    nw, pp = p.net, p.params
    z0 = nw.z_grid()
    if scr_after is None:
        zg, z_par = z0, None
    else:
        zg = z0 * nw.scr / scr_after
        z_par = z0 * zg / (zg - z0)
    g, t = pp.grid, pp.turbine
    _, _, aux = p._eval_cached()
    V = p._full_v(aux)
    v_pcc = complex(V[nw.pcc])
    i_pcc = complex((V[nw.on_hv] - V[nw.pcc]) / nw.z_ontr())  # into the PCC from the farm
    idx = plant.cases.visc_indices(n_visc)
    m = p.measurements()
    k = float(nw.k_t[idx[0]]) if n_visc else float(nw.k_t[0])
    i_unit0 = np.array([complex(m["i_d"][u], m["i_q"][u]) * k for u in idx])
    z_ttr = complex(g.r_ttr, g.x_ttr) * nw.sb / g.s_ttr_mva
    z_array, b_array = nw._cable(g.array_km, g.array_r_ohm_km, g.array_l_mh_km, g.array_c_nf_km, g.v_array_kv)
    z_export, b_export = nw._cable(g.export_km, g.export_r_ohm_km, g.export_l_mh_km, g.export_c_nf_km,
                                   g.v_export_kv)
    b_comp = g.comp_fraction * b_export / 2.0  # at each end, as plant/network.py
    z_otr = complex(g.r_otr, g.x_otr) * nw.sb / g.s_otr_mva
    zf = complex(t.rf, t.lf) / k
    zf_eq = zf / (1.0 + damping_k)  # the filter as the circuit sees it with the active damping inside (farm_run)
    n_agg = nw.n_farm - n_visc  # the aggregated turbines; their clusters: all but the SDViSCs' [assumed]
    k_agg = n_agg * t.s_rated_mva / g.s_base_mva
    n_cl_agg = pp.n_clusters - (1 if n_visc else 0)
    sc = None
    if with_sc:
        sc = p.X[p.layout.condenser:p.layout.grid].real.copy()

    def netlist_of(i_farm: complex, e_conv: list | None, e_sc: complex) -> netlist.Netlist:
        """``e_conv`` None: the converters as current sources (the load flow's unknown voltages)."""
        n = netlist.Netlist()
        n.add("V", "grid", "grid_src", netlist.GND, complex(g.e_grid))
        n.add("R", "grid_r", "grid_src", "grid_mid", zg.real)
        n.add("L", "grid_l", "grid_mid", "pcc", (zg.imag, zg.imag))
        n.add("L", "zero_seq_ground", "pcc", netlist.GND, (arrangement.OPEN_SEQUENCE_X, nw.z_ontr().imag))
        n.add("R", "damping", "pcc", netlist.GND, arrangement.R_DAMP)
        r_f = max(r_fault, arrangement.R_FAULT)
        n.add("S", "fault", "pcc", netlist.GND,
              (arrangement.R_OPEN, [r_f] * 3 if fault_kind == "3ph" else [r_f, arrangement.R_OPEN, arrangement.R_OPEN],
               False))
        if z_par is not None:  # the SCR step: a parallel grid branch, its breaker's poles open at 1 s
            n.add("R", "grid_par_r", "grid_src", "grid_par_mid", z_par.real)
            n.add("L", "grid_par_l", "grid_par_mid", "grid_par_end", (z_par.imag, z_par.imag))
            for ph in range(3):
                closed = [arrangement.R_OPEN] * 3
                closed[ph] = arrangement.R_FAULT
                n.add("S", f"grid_par_pole{ph}", "grid_par_end", "pcc", (arrangement.R_OPEN, closed, True))
        series = (("otr", "col", "os_hv", z_otr, arrangement.OPEN_SEQUENCE_X),  # YNd: no zero sequence
                  ("export", "os_hv", "on_hv", z_export, z_export.imag),
                  ("ontr", "on_hv", "pcc", nw.z_ontr(), arrangement.OPEN_SEQUENCE_X))
        for name, a, b, z, x0 in series:
            n.add("R", f"{name}_r", a, f"{name}_mid", z.real)
            n.add("L", f"{name}_l", f"{name}_mid", b, (z.imag, x0))
        for end in ("os_hv", "on_hv"):  # the export cable's charging (one pi) and its compensation reactors
            n.add("C", f"{end}_charging", end, netlist.GND, 0.5 * b_export)
            if b_comp > 0.0:
                n.add("L", f"{end}_reactor", end, netlist.GND, (1.0 / b_comp, 1.0 / b_comp))
        n.add("C", "array_charging", "col", netlist.GND, (pp.n_clusters - 0.5) * b_array)
        if farm_model == "gfl":  # the aggregated turbines behind their transformers and clusters' cables
            n.add("C", "cf_agg", "wt", netlist.GND, t.cf * k_agg)
            n.add("R", "ttr_agg_r", "wt", "wt_mid", z_ttr.real / n_agg)
            n.add("L", "ttr_agg_l", "wt_mid", "wcl", (z_ttr.imag / n_agg, arrangement.OPEN_SEQUENCE_X))
            n.add("R", "array_agg_r", "wcl", "wcl_mid", z_array.real / n_cl_agg)
            n.add("L", "array_agg_l", "wcl_mid", "col", (z_array.imag / n_cl_agg, z_array.imag / n_cl_agg))
            n.add("I", "farm", "wt", netlist.GND, i_farm)
        else:
            n.add("I", "farm", "col", netlist.GND, i_farm)
        if n_visc:
            n.add("C", "array_charging_cl", "cl", netlist.GND, 0.5 * b_array)
            n.add("R", "array_r", "cl", "array_mid", z_array.real)
            n.add("L", "array_l", "array_mid", "col", (z_array.imag, z_array.imag))
        for j in range(n_visc):
            n.add("C", f"cf{j}", f"t{j}", netlist.GND, t.cf * k)
            n.add("R", f"ttr_r{j}", f"t{j}", f"tm{j}", z_ttr.real)
            n.add("L", f"ttr{j}", f"tm{j}", "cl", (z_ttr.imag, arrangement.OPEN_SEQUENCE_X))
            if e_conv is None:
                n.add("I", f"conv{j}", f"t{j}", netlist.GND, i_unit0[j])
            else:
                n.add("V", f"conv{j}", f"c{j}", netlist.GND, e_conv[j])
                n.add("R", f"rf{j}", f"c{j}", f"m{j}", zf_eq.real)
                n.add("L", f"lf{j}", f"m{j}", f"t{j}", (zf_eq.imag, zf_eq.imag))
        if with_sc:
            zs, ztr = nw.z_sc_source(), nw.z_sc_tr()
            n.add("L", "sc_tr", "sc_t", "pcc", (ztr.imag, arrangement.OPEN_SEQUENCE_X))
            n.add("V", "sc_emf", "sc_src", netlist.GND, e_sc)
            n.add("R", "sc_ra", "sc_src", "sc_mid", zs.real)
            n.add("L", "sc_l", "sc_mid", "sc_t", (zs.imag, zs.imag))
        return n

    e_sc = complex(Condenser(pp.condenser).e_net(sc)) if with_sc else 0j
    i_target = i_pcc + v_pcc / arrangement.R_DAMP  # the path also feeds the PCC's damping resistor
    i_farm = i_target - i_unit0.sum()
    for _ in range(LOAD_FLOW_ITERATIONS):  # the farm's current such that the path delivers i_target
        lf_net = netlist_of(i_farm, None, e_sc)
        lf = netlist.load_flow(lf_net)
        i_farm += i_target - netlist.branch_current(lf_net, lf, "ontr_r")
    e_conv = [lf[f"t{j}"] + zf_eq * i_unit0[j] for j in range(n_visc)]
    net = netlist_of(i_farm, e_conv, e_sc)
    v0 = netlist.load_flow(net)
    params = [p.visc_params if m_q is None else p.visc_params.with_changes(m_q=float(np.asarray(m_q)[j]))
              for j in range(n_visc)]
    circ = FarmCircuit(net, v0, n_visc, k, zf, i_unit0, params, v0["col"] * np.conj(i_farm),
                       nw.n_farm * t.s_rated_mva / g.s_base_mva, sc, p.sc.v_ref if with_sc else 1.0,
                       farm_model, complex(i_farm), k_agg)
    return circ, p


class EmtFarm:
    """The stepped EMT run of :func:`build_case`'s circuit. The SDViSC converters hold their start-up
    voltage (P = 0, as the phasor plant's turbines before the OWFCC's request) until :meth:`activate`,
    then follow the ViSC law (sdc_unit's equations at every circuit step, the HD ViSC as F8's hd_visc),
    each with its own droop; the aggregated farm's current is recomputed every Ts from its node's
    positive-sequence voltage (devices.FarmInjection, its fault ride-through). ``meas``: what the SDViSCs' law
    measures (frame.MEASUREMENTS: the raw Park phasors, or positive sequences by delayed-signal cancellation;
    farm_run's module docstring)."""

    def __init__(self, n_visc: int = 4, m_q=(0.03, 0.05, 0.07, 0.10), with_sc: bool = False,
                 steps_per_ts: int = STEPS_PER_TS, r_fault: float = arrangement.R_FAULT,
                 scr_after: float | None = None, visc_params: ViscParams | None = None,
                 k_ad: float = K_AD_PARALLEL, farm_model: str = "injection", exchange: str = "step",
                 record_every_step: bool = False, fault_kind: str = "slg", meas: str = "park", **grid):
        if exchange not in EXCHANGES:
            raise ValueError(f"exchange {exchange!r}: one of {', '.join(EXCHANGES)}")
        if meas not in frame.MEASUREMENTS:
            raise ValueError(f"meas {meas!r}: one of {', '.join(frame.MEASUREMENTS)}")
        self.meas = meas  # the SDViSCs' law measures the raw Park phasors or their positive sequence (farm_run)
        self.exchange = exchange
        self.record_every_step = record_every_step
        self.circ, self.phasor_plant = build_case(n_visc, m_q, with_sc, r_fault, scr_after, visc_params,
                                                  farm_model, k_ad if exchange == "ts" else 0.0, fault_kind, **grid)
        self.h = TS_S / steps_per_ts
        self.n_sub = steps_per_ts
        self.k_ad = k_ad
        pp = self.phasor_plant.params
        self.w_ad = pp.turbine.w_ad
        self.farm = FarmInjection(self.circ.farm_s, self.circ.farm_rating, pp.turbine)
        self.units: list[ViscConverter | None] = [None] * n_visc
        self.sdc: DiscreteVisc | None = None  # the SDC's discrete ViSCs (exchange "ts") once activated
        self.sc = (CondenserEmf(pp.condenser, self.circ.sc_state, self.circ.sc_v_ref, self.phasor_plant.net.k_sc)
                   if with_sc else None)
        # each SDViSC's latest (terminal voltage, converter current) phasors: the load flow's until the first step
        self._last = [(self.circ.v0[f"t{j}"], complex(self.circ.i_unit0[j])) for j in range(n_visc)]
        self._opening = False  # the SCR step's breaker: poles open at their current's zeros from the event
        wpp = self.phasor_plant.wpp  # the plant controller (plant/wpp.py) where the phasor plant has one, settled
        self.wpp = copy.deepcopy(wpp) if wpp is not None else None
        if self.wpp is not None:  # its order (turbine base) scaled to the aggregated farm's turbines
            self._q_order0, self._q_farm0 = float(self.wpp.q_turbines), self.circ.farm_s.imag
            self._q_scale = (self.phasor_plant.net.n_farm - n_visc) * pp.turbine.s_rated_mva / pp.grid.s_base_mva
        self._e = [self.circ.v0[f"c{j}"] for j in range(n_visc)]
        self.gfl = (GflAggregate(self.circ.v0["wt"], self.circ.farm_i0, self.circ.k_agg, TS_S, pp.turbine)
                    if farm_model == "gfl" else None)

    def activate(self, run=None) -> None:
        """Every SDViSC switches to the ViSC law, bumpless at its present terminal voltage and current: the
        continuous law per unit (exchange ``step``), the SDC's discrete ViSCs (``ts``, all in one)."""
        if self.exchange == "ts":
            if self.circ.n_visc:
                ps = self.circ.visc_params
                self.sdc = DiscreteVisc(self.circ.n_visc, ps[0], TS_S, "tustin")
                self.sdc.rp["m_q"][:] = [float(p.m_q) for p in ps]
                self.sdc.initialise(np.arange(self.circ.n_visc), sdc_measurements(self._last, self.circ.k_unit))
            return
        tp = self.phasor_plant.params.turbine
        for j, (v, i) in enumerate(self._last):
            p = self.circ.visc_params[j]
            x0 = law.initial_state(law.Measurements.from_complex(v, i / self.circ.k_unit), p)
            self.units[j] = ViscConverter(p, x0, self.circ.k_unit, v, self._e[j], tp)
            self.units[j].k_ad = self.k_ad

    def scr_step(self, run=None) -> None:
        """An event: the parallel grid branch's breaker opens, each pole at its current's next zero (the grid
        then has ``scr_after``'s impedance; built with ``scr_after`` only)."""
        self._opening = True

    def run(self, t_end: float, events: list | None = None, fault: tuple[float, float] | None = None) -> dict:
        """As :meth:`plant.emt.model.EmtComparison.run`: ``events`` [(t, callable(run))], ``fault`` (on, off)
        of a bolted SLG fault (phase a) at the PCC (plant/emt/farm_run.py). Returns every step's phase voltages
        at the PCC (``v_pcc_abc``, times ``t``), the SDViSC terminals' (``v_t_abc``, [record, unit, phase]) and
        their converter currents (``i_abc``, network base) at the record times ``t_ts`` (every step, or every
        Ts with ``exchange="ts"`` unless ``record_every_step``), Park phasors of each, ``cpu_s``, ``wall_s``."""
        return run_farm(self, t_end, events, fault)
