"""A three-phase circuit written once as a list of elements, from which both its positive-sequence phasor
load flow (numpy, for the initial node voltages) and its DPsim EMT system are built: the EMT run then
starts in the steady state of the very circuit it steps (``do_init_from_nodes_and_terminals``).

Per unit on the network base with a 1 ohm impedance base (as plant/emt/arrangement.py): a resistance r is
r ohm, a reactance x is an inductance x/omega0, a susceptance b a capacitance b/omega0. Kinds:

* ``R`` r, ``L`` (x1, x0) (3x3 inductance, arrangement.sequence_inductance), ``C`` b: between a and b;
* ``V`` E: a voltage source from ground to a (its phasor set every step by the run);
* ``I`` I: a current source injecting I into a from ground;
* ``S`` (r_open, r_closed_per_phase, closed): a switch a to b, closed at the start if ``closed`` (a pole
  of a breaker: closed on one phase only; the load flow takes its positive-sequence admittance as the
  mean of its phases', so three such poles, one per phase, make a closed three-phase switch).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from plant.emt import arrangement
from plant.emt.dpsim_env import dpsim
from sdvisc.vocabulary import OMEGA0

GND = "gnd"


@dataclass(frozen=True)
class Element:
    kind: str
    name: str
    a: str
    b: str
    value: object


@dataclass
class Netlist:
    elements: list[Element] = field(default_factory=list)

    def add(self, kind: str, name: str, a: str, b: str, value) -> None:
        if kind not in "RLCVIS" or len(kind) != 1:
            raise ValueError(f"element {name!r}: unknown kind {kind!r}")
        if any(e.name == name for e in self.elements):
            raise ValueError(f"element {name!r} added twice")
        self.elements.append(Element(kind, name, a, b, value))

    def node_names(self) -> list[str]:
        seen: dict[str, None] = {}
        for e in self.elements:
            for n in (e.a, e.b):
                if n != GND:
                    seen.setdefault(n)
        return list(seen)

    def __getitem__(self, name: str) -> Element:
        for e in self.elements:
            if e.name == name:
                return e
        raise KeyError(name)


def _admittance(e: Element) -> complex:
    if e.kind == "R":
        return 1.0 / e.value
    if e.kind == "L":
        return 1.0 / (1j * e.value[0])
    if e.kind == "C":
        return 1j * e.value
    if e.kind == "S":
        return float(np.mean(1.0 / np.asarray(e.value[1]))) if e.value[2] else 1.0 / e.value[0]
    raise ValueError(e.kind)


def load_flow(net: Netlist) -> dict[str, complex]:
    """The positive-sequence steady state: every node's phasor (sources as given, switches open)."""
    names = net.node_names()
    fixed = {e.a: complex(e.value) for e in net.elements if e.kind == "V"}
    free = [n for n in names if n not in fixed]
    ix = {n: k for k, n in enumerate(free)}
    y = np.zeros((len(free), len(free)), dtype=complex)
    rhs = np.zeros(len(free), dtype=complex)
    for e in net.elements:
        if e.kind == "V":
            continue
        if e.kind == "I":
            if e.a in ix:
                rhs[ix[e.a]] += e.value
            continue
        g = _admittance(e)
        for p, q in ((e.a, e.b), (e.b, e.a)):
            if p in ix:
                y[ix[p], ix[p]] += g
                if q in ix:
                    y[ix[p], ix[q]] -= g
                elif q != GND:
                    rhs[ix[p]] += g * fixed[q]
    v = np.linalg.solve(y, rhs)
    return {**fixed, **{n: complex(v[ix[n]]) for n in free}}


def branch_current(net: Netlist, v: dict[str, complex], name: str) -> complex:
    """The phasor current a -> b of a passive element ``name`` at node voltages ``v``."""
    e = net[name]
    va, vb = v.get(e.a, 0j) if e.a != GND else 0j, v.get(e.b, 0j) if e.b != GND else 0j
    return (va - vb) * _admittance(e)


@dataclass
class Built:
    sys: object
    nodes: dict
    comps: dict


def build(net: Netlist, v0: dict[str, complex]) -> Built:
    """The DPsim EMT system of ``net`` with its nodes initialised at ``v0`` (:func:`load_flow`)."""
    d = dpsim()
    ph3 = d.emt.ph3
    conv = d.Math.single_phase_variable_to_three_phase
    nodes = {n: arrangement.three_phase_node(n, v0[n]) for n in net.node_names()}
    nodes[GND] = d.emt.SimNode.gnd
    comps = {}
    for e in net.elements:
        if e.kind == "R":
            c, params, ends = ph3.Resistor(e.name), (arrangement.diag3(e.value),), (e.a, e.b)
        elif e.kind == "L":
            c, params, ends = ph3.Inductor(e.name), (arrangement.sequence_inductance(*e.value),), (e.a, e.b)
        elif e.kind == "C":
            c, params, ends = ph3.Capacitor(e.name), (arrangement.diag3(e.value / OMEGA0),), (e.a, e.b)
        elif e.kind == "V":
            c, params, ends = ph3.VoltageSource(e.name), (conv(complex(e.value)), 50.0), (GND, e.a)
        elif e.kind == "I":  # DPsim's I_ref is a phase RMS: 1 p.u. of current is 1/sqrt(3) (model.py's farm)
            c, params, ends = ph3.CurrentSource(e.name), (conv(complex(e.value) / np.sqrt(3.0)), 50.0), (e.a, GND)
        else:
            r_open, closed, on = e.value
            c, params, ends = ph3.Switch(e.name), (arrangement.diag3(r_open), np.diag(closed), bool(on)), (e.a, e.b)
        c.set_parameters(*params)
        c.connect([nodes[ends[0]], nodes[ends[1]]])
        comps[e.name] = c
    sys = d.SystemTopology(50, [n for k, n in nodes.items() if k != GND], list(comps.values()))
    return Built(sys, nodes, comps)
