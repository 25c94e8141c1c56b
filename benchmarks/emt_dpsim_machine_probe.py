"""DPsim's own reduced-order synchronous machines (emt.ph3.SynchronGenerator{4,6a,6b}OrderVBR) as the 40 MVA
SC of the comparison arrangement, against the subtransient closed form after a bolted three-phase fault at
the PCC: why plant/emt/ uses E'' behind r_a + j x''_d with the project's condenser model instead
(docs/plant.md, "EMT backend").

The circuit: the grid source behind Z_g, the farm's injection, the SC behind its step-up (diagonal
inductor), a three-phase fault switch at the PCC closed at 0.1 s; the machine in per unit on our 40 MVA
data (CondenserParams; x'_q = 0.5 and T'_q0 = 0.5 s [assumed: DPsim's models need a q-axis transient
winding; with x'_q = x_q the 6b model is worse]), Norton form with system-matrix recomputation (issue 40's
probe), initialised at no load at the phasor plant's terminal voltage. Prints one JSON document: per model
the AC current (half-cycle mean of the Park phasor, p.u. on 40 MVA) at 5, 20, 40 ms after the fault and
the closed form (I' + (I'' - I') e^{-t/T''_d}, Kundur 1994 sec. 5.3).

Usage: nice -n 10 .venv/bin/python benchmarks/emt_dpsim_machine_probe.py [--out FILE]
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from plant.emt import arrangement, frame
from plant.emt.dpsim_env import dpsim
from plant.emt.operating_point import from_phasor_plant
from sdvisc.jsonlines import write_json_atomic
from sdvisc.vocabulary import OMEGA0

XQ1, TQ01 = 0.5, 0.5  # [assumed] q-axis transient data the DPsim models need
T_ON, AFTER = 0.1, (0.005, 0.02, 0.04)


def machine(d, order: str, c, k):
    sg = getattr(d.emt.ph3, f"SynchronGenerator{order}OrderVBR")("sg")
    common = (k, 1.0, 50.0, c.h, c.xd, c.xq, 0.1, c.xd1, XQ1, c.td01, TQ01)
    if order == "4":
        sg.set_operational_parameters_per_unit(*common)
    elif order == "6a":
        sg.set_operational_parameters_per_unit(*common, c.xd2, c.xd2, c.td02, c.tq02, 0.0)
    else:
        sg.set_operational_parameters_per_unit(*common, c.xd2, c.xd2, c.td02, c.tq02)
    return sg


def run(order: str) -> dict:
    d = dpsim()
    ph3, gnd = d.emt.ph3, d.emt.SimNode.gnd
    op, p = from_phasor_plant("sc")
    c = p.params.condenser
    h = 0.67e-3 / 13
    zg = op.z_grid
    i_g = (op.e_grid - op.v_pcc) / zg
    nodes = {n: arrangement.three_phase_node(n, v) for n, v in
             (("pcc", op.v_pcc), ("gs", op.e_grid), ("gm", op.e_grid - zg.real * i_g), ("t", op.v_terminal))}
    comps = []

    def comp(cls, name, params, a, b):
        x = getattr(ph3, cls)(name)
        x.set_parameters(*params)
        x.connect([a, b])
        comps.append(x)
        return x

    comp("VoltageSource", "g", (d.Math.single_phase_variable_to_three_phase(op.e_grid), 50.0), gnd, nodes["gs"])
    comp("Resistor", "gr", (arrangement.diag3(zg.real),), nodes["gs"], nodes["gm"])
    comp("Inductor", "gl", (arrangement.diag3(zg.imag / OMEGA0),), nodes["gm"], nodes["pcc"])
    comp("CurrentSource", "farm", (d.Math.single_phase_variable_to_three_phase(op.i_farm / np.sqrt(3.0)), 50.0),
         nodes["pcc"], gnd)
    tr = comp("Inductor", "tr", (arrangement.diag3(op.z_step_up.imag / OMEGA0),), nodes["t"], nodes["pcc"])
    sg = machine(d, order, c, op.k_device)
    sg.set_initial_values(0j, 0.0, op.v_terminal)
    sg.set_model_as_norton_source(True)
    sg.connect([nodes["t"]])
    comps.append(sg)
    sw = comp("Switch", "f", (arrangement.diag3(1e8), arrangement.diag3(1e-4), False), nodes["pcc"], gnd)
    sim = d.Simulation(f"sg{order}", d.LogLevel.off)
    sim.set_system(d.SystemTopology(50, list(nodes.values()), comps))
    sim.set_domain(d.Domain.EMT)
    sim.set_time_step(h)
    sim.set_final_time(1.0)
    sim.do_init_from_nodes_and_terminals(True)
    sim.do_system_matrix_recomputation(True)
    sim.add_event(d.event.SwitchEvent3Ph(round(T_ON / h) * h - 0.5 * h, sw, True))
    n = int(0.16 / h)
    cur = np.zeros((n, 3))
    sim.start()
    for k in range(n):
        sim.next()
        cur[k] = np.ravel(tr.attr("i_intf").get())
    sim.stop()
    t = (np.arange(n) + 1) * h
    i = -frame.park(cur, t) / op.k_device  # out of the machine, 40 MVA base
    half = int(round(0.01 / h))
    ac = {}
    for s in AFTER:
        k0 = int(np.searchsorted(t, T_ON + s))
        ac[f"{s * 1e3:g} ms"] = float(abs(0.5 * (i[k0] + i[k0 + half])))
    td2 = c.td02 * (c.xd2 + c.x_tr) / (c.xd1 + c.x_tr)
    e2 = abs(op.e_source)
    i2, i1 = e2 / (c.xd2 + c.x_tr), e2 / (c.xd1 + c.x_tr)
    closed = {f"{s * 1e3:g} ms": float(np.mean([i1 + (i2 - i1) * np.exp(-x / td2) for x in (s, s + 0.01)]))
              for s in AFTER}
    return {"ac_current": ac, "closed_form": closed,
            "pre_fault_current": float(abs(i[int(0.09 / h)])),
            "largest_phase_peak_after": float(np.abs(cur[t >= T_ON]).max() / frame.PEAK_PER_PU / op.k_device)}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="")
    args = ap.parse_args()
    out = {"what": "DPsim 1.4.0 reduced-order machines, three-phase fault at the PCC (benchmarks/emt_dpsim_machine_probe.py)",
           "results": {order: run(order) for order in ("4", "6a", "6b")}}
    print(json.dumps(out, indent=1))
    if args.out:
        write_json_atomic(args.out, out)


if __name__ == "__main__":
    main()
