"""The comparison arrangement (paper, Section IV-B) as a DPsim EMT circuit, per unit on the network base.

Elements (the phasor plant's values, plant/network.py, from the same ``PlantParams``):

* grid: ``emt.ph3.VoltageSource`` E_g (``GridParams.e_grid``, angle 0: the phasor plant's reference)
  behind ``Resistor`` + ``Inductor`` Z_g = 1/SCR at R/X ``r_over_x`` (k0 = 1: no mutual coupling, Z0 = Z1);
* the farm (50 turbines, collector, export cable, onshore transformer) as one grid-following
  ``emt.ph3.CurrentSource`` at the PCC carrying the current the phasor plant's onshore transformer
  delivers there (:mod:`plant.emt.devices`, ``FarmInjection``);
* YNd step-ups (star grounded at the PCC, plant/network.py's ``z_zero``): a series ``Inductor`` with a
  3x3 matrix, positive/negative-sequence reactance x_tr and no zero-sequence path (the delta), plus one
  grounding ``Inductor`` at the PCC passing the zero sequence only, with the parallel of the YNd
  zero-sequence reactances (onshore 220/400 kV transformer, and the device's step-up);
* the SC: its subtransient EMF E'' (``VoltageSource``, set every step from the project's condenser
  model, :class:`plant.emt.devices.CondenserEmf`) behind ``Resistor`` r_a + ``Inductor`` x''_d;
* the SDViSC: the converter's average model, a ``VoltageSource`` whose phasor is the ViSC law's
  v_ref (set every Ts) behind its filter r_f + l_f, the filter capacitor c_f at its terminal
  (``Capacitor``), its aggregated turbine transformers and step-up;
* the fault: ``emt.ph3.Switch`` PCC to ground, closed on phase a (SLG) or on all three phases.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from plant.emt.dpsim_env import dpsim
from sdvisc.vocabulary import OMEGA0

R_FAULT = 1e-4
"""Closed fault switch resistance per phase, p.u. (network base) [assumed: a bolted fault, as the phasor
plant's z_f = 0; 1e-4 p.u. = 32 mOhm at 400 kV]."""
R_OPEN = 1e8
"""Open switch resistance, p.u. [assumed: an open circuit]."""
R_DAMP = 1e3
"""Shunt resistance per phase at the PCC, p.u. (network base) [assumed: 0.5 MW at 1 p.u., 0.1 % of the farm;
the farm's injection carries its current in the operating point]. Without it the PCC is a node of inductors
and current sources only, and the trapezoidal rule rings undamped at the Nyquist frequency after any step of
di/dt (after the fault's clearance: 2.3 p.u. at 9.7 kHz on phase a, measured); with it the ring decays in a
few ms."""
OPEN_SEQUENCE_X = 1e4
"""Reactance standing for an open sequence path in the coupled inductors, p.u. [assumed: 1e4 p.u. on
500 MVA passes 1e-4 p.u. of current at 1 p.u., negligible]."""


def sequence_inductance(x1: float, x0: float) -> np.ndarray:
    """3x3 inductance matrix [H at 1 ohm base] with positive/negative-sequence reactance x1 and
    zero-sequence reactance x0 (p.u. at omega0): L = L1 I + (L0 - L1)/3 ones."""
    l1, l0 = x1 / OMEGA0, x0 / OMEGA0
    return l1 * np.eye(3) + (l0 - l1) / 3.0 * np.ones((3, 3))


def diag3(x: float) -> np.ndarray:
    return x * np.eye(3)


@dataclass
class Circuit:
    """The built DPsim system and the handles the run reads and sets."""

    sys: object
    nodes: dict
    comps: dict
    fault_switch: object
    names: list = field(default_factory=list)


def three_phase_node(name: str, v: complex):
    d = dpsim()
    return d.emt.SimNode(name, d.PhaseType.ABC, list(np.ravel(d.Math.single_phase_variable_to_three_phase(v))))


def build(op, fault_kind: str = "slg") -> Circuit:
    """The circuit of operating point ``op`` (:class:`plant.emt.operating_point.OperatingPoint`)."""
    d = dpsim()
    ph3 = d.emt.ph3
    gnd = d.emt.SimNode.gnd
    nodes, comps = {}, {}

    def node(name, v):
        nodes[name] = three_phase_node(name, v)
        return nodes[name]

    def comp(cls, name, params, a, b):
        c = getattr(ph3, cls)(name)
        c.set_parameters(*params)
        c.connect([a, b])
        comps[name] = c
        return c

    pcc = node("pcc", op.v_pcc)
    zg = op.z_grid
    i_g = (op.e_grid - op.v_pcc) / zg
    n_gs, n_gm = node("grid_src", op.e_grid), node("grid_mid", op.e_grid - zg.real * i_g)
    comp("VoltageSource", "grid", (d.Math.single_phase_variable_to_three_phase(op.e_grid), 50.0), gnd, n_gs)
    comp("Resistor", "grid_r", (diag3(zg.real),), n_gs, n_gm)
    comp("Inductor", "grid_l", (diag3(zg.imag / OMEGA0),), n_gm, pcc)
    i_farm = op.i_farm + op.v_pcc / R_DAMP  # the farm also feeds the damping resistor (operating point kept)
    comp("CurrentSource", "farm", (d.Math.single_phase_variable_to_three_phase(i_farm / np.sqrt(3.0)), 50.0), pcc, gnd)
    comp("Inductor", "zero_seq_ground", (sequence_inductance(OPEN_SEQUENCE_X, op.x0_ground),), pcc, gnd)
    comp("Resistor", "damping", (diag3(R_DAMP),), pcc, gnd)
    if op.device == "sc":
        z_tr, zs = op.z_step_up, op.z_source
        i = op.i_device
        v_t = op.v_terminal
        n_t, n_m, n_e = node("sc_t", v_t), node("sc_mid", op.e_source - zs.real * i), node("sc_src", op.e_source)
        comp("Inductor", "sc_tr", (sequence_inductance(z_tr.imag, OPEN_SEQUENCE_X),), n_t, pcc)
        comp("VoltageSource", "sc_emf", (d.Math.single_phase_variable_to_three_phase(op.e_source), 50.0), gnd, n_e)
        comp("Resistor", "sc_ra", (diag3(zs.real),), n_e, n_m)
        comp("Inductor", "sc_l", (diag3(zs.imag / OMEGA0),), n_m, n_t)
    elif op.device == "visc":
        z_tr, zf = op.z_step_up, op.z_source
        i, v_t = op.i_device, op.v_terminal
        i_tr = i - 1j * op.b_filter * v_t  # the filter capacitor (admittance j b) takes j b v
        n_c, n_m = node("visc_conv", op.e_source), node("visc_mid", op.e_source - zf.real * i)
        n_t, n_tm = node("visc_t", v_t), node("visc_tmid", v_t - z_tr.real * i_tr)
        comp("VoltageSource", "visc_conv", (d.Math.single_phase_variable_to_three_phase(op.e_source), 50.0), gnd, n_c)
        comp("Resistor", "visc_rf", (diag3(zf.real),), n_c, n_m)
        comp("Inductor", "visc_lf", (diag3(zf.imag / OMEGA0),), n_m, n_t)
        comp("Capacitor", "visc_cf", (diag3(op.b_filter / OMEGA0),), n_t, gnd)
        comp("Resistor", "visc_tr_r", (diag3(z_tr.real),), n_t, n_tm)
        comp("Inductor", "visc_tr", (sequence_inductance(z_tr.imag, OPEN_SEQUENCE_X),), n_tm, pcc)
    closed = diag3(R_FAULT) if fault_kind == "3ph" else np.diag([R_FAULT, R_OPEN, R_OPEN])
    sw = comp("Switch", "fault", (diag3(R_OPEN), closed, False), pcc, gnd)
    sys = d.SystemTopology(50, list(nodes.values()), list(comps.values()))
    return Circuit(sys, nodes, comps, sw)
