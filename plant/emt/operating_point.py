"""The EMT circuit's operating point and element values, taken from the phasor plant (plant/cases.py's
set-ups on the same ``PlantParams``): both models start from the same load flow, so a difference after
an event is the model's, not the initialisation's."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import plant.cases
from plant.condenser import Condenser


@dataclass
class OperatingPoint:
    """Per unit on the network base (500 MVA) unless said; angles in the common frame."""

    device: str  # "sc", "visc" or "none"
    e_grid: complex
    z_grid: complex
    v_pcc: complex
    i_farm: complex  # into the PCC from the farm's onshore transformer
    x0_ground: float  # zero-sequence reactance of the YNd windings grounded at the PCC (in parallel)
    k_device: float = 0.0  # device rating / network base
    z_step_up: complex = 0j  # PCC <-> device terminal (positive/negative sequence)
    z_source: complex = 0j  # SC: r_a + j x''_d; SDViSC: the filter r_f + j l_f (network base)
    e_source: complex = 0j  # SC: E''; SDViSC: the converter voltage
    v_terminal: complex = 0j
    i_device: complex = 0j  # out of the source (network base)
    b_filter: float = 0.0  # SDViSC's filter capacitor susceptance (network base)
    condenser_state: np.ndarray | None = None
    condenser_v_ref: float = 1.0
    law_state: np.ndarray | None = None
    visc_params: object = None


def _par(*xs: float) -> float:
    return 1.0 / sum(1.0 / x for x in xs)


def from_phasor_plant(device: str, **grid) -> tuple[OperatingPoint, object]:
    """(operating point, the phasor Plant it came from) for ``device`` "sc" (plant.cases.sc_plant),
    "visc" (comparison_visc_plant, the 40 MVA SDViSC at P = 0) or "none" (bare_plant)."""
    make = {"sc": plant.cases.sc_plant, "visc": plant.cases.comparison_visc_plant,
            "none": plant.cases.bare_plant}[device]
    p = make(**grid)
    net, pp = p.net, p.params
    _, _, aux = p._eval_cached()
    V = p._full_v(aux)
    z_ontr = net.z_ontr()
    i_farm = (V[net.on_hv] - V[net.pcc]) / z_ontr
    x0 = [z_ontr.imag]
    op = OperatingPoint(device, complex(pp.grid.e_grid), net.z_grid(), complex(V[net.pcc]), complex(i_farm), 0.0)
    if device == "sc":
        c = pp.condenser
        op.k_device = net.k_sc
        op.z_step_up, op.z_source = net.z_sc_tr(), net.z_sc_source()
        x_sc = p.X[p.layout.condenser:p.layout.grid].real.copy()
        op.condenser_state, op.condenser_v_ref = x_sc, p.sc.v_ref
        op.e_source = complex(Condenser(c).e_net(x_sc))
        op.v_terminal = complex(V[net.sc])
        op.i_device = (op.e_source - op.v_terminal) / op.z_source
        x0.append(op.z_step_up.imag)
    elif device == "visc":
        u = plant.cases.COMPARISON_UNIT
        t = pp.turbine
        op.k_device = float(net.k_t[u])
        op.z_step_up = net.z_onshore_unit()
        op.z_source = complex(t.rf, t.lf) / op.k_device
        op.b_filter = t.cf * op.k_device
        m = p.measurements()
        v = complex(m["v_d"][u], m["v_q"][u])
        i_unit = complex(m["i_d"][u], m["i_q"][u])
        op.v_terminal = v
        op.i_device = i_unit * op.k_device
        op.e_source = v + complex(t.rf, t.lf) * i_unit
        op.law_state = np.array(p.xl, dtype=float).copy()
        op.visc_params = p.visc_params
        x0.append(complex(0.0, pp.x_onshore_step_up).imag * pp.grid.s_base_mva / pp.onshore_unit_mva)
    op.x0_ground = _par(*x0)
    return op, p


def phasor_farm_current(device: str, t_end: float, events: list, **grid) -> tuple[np.ndarray, np.ndarray]:
    """(t, I_farm(t)): the current the phasor plant's onshore transformer delivers at the PCC (network
    base, positive sequence) at every step of a run of ``device``'s set-up with ``events``, for
    :class:`plant.emt.devices.FarmReplay`."""
    _, p = from_phasor_plant(device, **grid)
    net = p.net
    ev = sorted(events, key=lambda e: e[0])
    ts, cur = [], []
    n = int(round(t_end / p.step_s))
    while p.k < n:
        while ev and ev[0][0] <= p.t + 0.5 * p.step_s:
            ev.pop(0)[1](p)
        _, _, aux = p._eval_cached()
        v = p._full_v(aux)
        ts.append(p.t)
        cur.append((v[net.on_hv] - v[net.pcc]) / net.z_ontr())
        p.step()
    return np.array(ts), np.array(cur)
