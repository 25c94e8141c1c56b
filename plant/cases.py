"""The paper's farm set-ups (Section IV) on the offline 50-turbine plant, written once for the
plant's tests and the paper report. Two arrangements: the comparison with the SC (F3–F7) has one
aggregated 40 MVA SDViSC at the onshore PCC (``comparison_visc_plant``), as the SC; the farm cases
(F8, F9, and the cluster variant of F3–F7) use the leftmost turbines of cluster 3 (index 20
on) at P = 0 (a ViSC has T_m = 0: it starts from P = 0, the pitch sheds the wind), the SC out of
service in the SDViSC cases, SCR 7.14 unless a grid key says otherwise. Here an SDViSC is the
continuous law inside the plant (``hd_visc``); plant/cosim.py steps the discrete SDC instead."""

from __future__ import annotations

import numpy as np

from plant.params import PlantParams
from plant.sim import Plant
from sdc_unit.params import ViscParams

FIRST_VISC = 20  # "the leftmost 4 wind turbines in Cluster 3"
COMPARISON_UNIT = 50  # the onshore aggregated SDViSC: the first converter after the 50 farm turbines


def visc_indices(n: int) -> np.ndarray:
    return np.arange(FIRST_VISC, FIRST_VISC + n)


def visc_plant(n: int = 4, visc_params: ViscParams | None = None, activate: bool = True, battery: bool = False,
               **grid) -> Plant:
    """The farm with ``n`` SDViSC turbines (hd_visc), the SC out of service."""
    pp = _params(False, grid)
    pp.visc_params = visc_params or ViscParams()
    return _with_visc(Plant(pp), visc_indices(n), activate, battery)


def comparison_visc_plant(visc_params: ViscParams | None = None, activate: bool = True, battery: bool = False,
                          **grid) -> Plant:
    """The paper's comparison arrangement (Section IV-A): one SDViSC of 40 MVA, four 10 MW turbine
    converters aggregated as one equivalent with its own transformers, at the onshore PCC beside
    the 50-turbine farm (all producing), the SC out of service. The unit is converter index
    ``COMPARISON_UNIT`` (= 50, after the farm's turbines), at P = 0 (a ViSC has T_m = 0)."""
    pp = _params(False, grid)
    pp.onshore_units = 1
    pp.visc_params = visc_params or ViscParams()
    return _with_visc(Plant(pp), np.array([COMPARISON_UNIT]), activate, battery)


def _with_visc(plant: Plant, idx: np.ndarray, activate: bool, battery: bool) -> Plant:
    """The converters ``idx`` taken to P = 0 (steady state anew), their batteries, then hd_visc."""
    if idx.size:
        plant.set_power_ref(idx, p=0.0)
        plant.reinitialise()
        if battery:
            plant.set_battery(idx, True)
        if activate:
            plant.set_mode(idx, "hd_visc")
    return plant


def sc_plant(h_sc: float | None = None, **grid) -> Plant:
    """The farm with the 40 MVA synchronous condenser in service (no SDViSC)."""
    pp = _params(True, grid)
    if h_sc is not None:
        pp.condenser.h = h_sc
    return Plant(pp)


def bare_plant(**grid) -> Plant:
    """The farm with neither SC nor SDViSC."""
    return Plant(_params(False, grid))


def _params(sc_connected: bool, grid: dict) -> PlantParams:
    """The plant's parameters with the SC in or out of service and the grid keys ``grid``
    (``plant.params.GridParams`` fields, e.g. ``scr``, ``e_grid``, ``h``) set; ``wpp_enabled=False``
    among them takes the plant controller out of voltage control: IEC 61400-27-1's reactive-power
    control mode at Q* = 0, whose steady state is every turbine at unity power factor."""
    grid = dict(grid)
    pp = PlantParams(sc_connected=sc_connected)
    pp.wpp.enabled = bool(grid.pop("wpp_enabled", pp.wpp.enabled))
    for key, value in grid.items():
        if not hasattr(pp.grid, key):
            raise TypeError(f"unknown grid parameter {key!r}")
        setattr(pp.grid, key, value)
    return pp
