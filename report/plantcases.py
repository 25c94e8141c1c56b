"""The paper's plant set-ups on the offline 50-turbine farm (plant.sim), as tests/unit/
test_plant_behaviour.py builds them: SDViSCs are the leftmost turbines of cluster 3 (index 20 on)
at P = 0 (T_m = 0), SC out of service in the SDViSC cases, SCR 7.14. Here the SDViSCs are the
continuous law inside the plant (``hd_visc``); plant/cosim.py steps the discrete SDC instead."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from plant.params import PlantParams
from plant.sim import Plant
from sdc_unit.params import ViscParams

FIRST_VISC = 20  # "the leftmost 4 wind turbines in Cluster 3"
FAULT_SLG = "single-phase-to-ground fault at the PCC"
V_BAND = 0.9  # p.u.: a weak-grid case "holds" (a usable operating point) when V_pcc settles at or above this
PTP_SETTLED = 0.02  # p.u.: peak-to-peak of V_pcc over the last second below this = settled


def visc_indices(n: int) -> np.ndarray:
    return np.arange(FIRST_VISC, FIRST_VISC + n)


def visc_plant(n: int = 4, visc_params: ViscParams | None = None, activate: bool = True, battery: bool = False,
               **grid) -> Plant:
    """The farm with ``n`` SDViSC turbines (hd_visc), the SC out of service."""
    pp = PlantParams(sc_connected=False)
    for key, value in grid.items():
        setattr(pp.grid, key, value)
    pp.visc_params = visc_params or ViscParams()
    plant = Plant(pp)
    if n:
        idx = visc_indices(n)
        plant.set_power_ref(idx, p=0.0)
        plant.reinitialise()
        if battery:
            plant.set_battery(idx, True)
        if activate:
            plant.set_mode(idx, "hd_visc")
    return plant


def sc_plant(h_sc: float | None = None, **grid) -> Plant:
    """The farm with the 40 MVA synchronous condenser in service (no SDViSC)."""
    pp = PlantParams(sc_connected=True)
    if h_sc is not None:
        pp.condenser.h = h_sc
    for key, value in grid.items():
        setattr(pp.grid, key, value)
    return Plant(pp)


def bare_plant(**grid) -> Plant:
    """The farm with neither SC nor SDViSC."""
    pp = PlantParams(sc_connected=False)
    for key, value in grid.items():
        setattr(pp.grid, key, value)
    return Plant(pp)


def window(r: dict, t0: float, t1: float) -> np.ndarray:
    return (r["t"] >= t0) & (r["t"] < t1)


@dataclass
class Settling:
    v_end: float  # V_pcc at the end [p.u.]
    ptp_last_s: float  # peak-to-peak of V_pcc over the last second [p.u.]
    v_min: float  # lowest V_pcc after the event [p.u.]
    finite: bool = True  # False: the simulation diverged (non-finite values)

    @property
    def settled(self) -> bool:
        """No sustained oscillation: what "stable" means in the weak-grid searches."""
        return self.finite and self.ptp_last_s < PTP_SETTLED

    @property
    def holds(self) -> bool:
        """Settled within the voltage band (a usable operating point)."""
        return self.settled and self.v_end >= V_BAND

    def describe(self) -> str:
        if not self.finite:
            return "diverged (non-finite V_pcc)"
        state = ("settles in the band" if self.holds else f"settles below {V_BAND} p.u." if self.settled
                 else "oscillates")
        return f"{state}: V_pcc end {self.v_end:.3f}, p-p last 1 s {self.ptp_last_s:.3f}, min {self.v_min:.3f}"


def settling(r: dict, t_event: float) -> Settling:
    t_end = r["t"][-1]
    last = window(r, t_end - 1.0, t_end + 1.0)
    after = r["t"] > t_event
    v = r["v_pcc"]
    return Settling(float(v[-1]), float(np.ptp(v[last])), float(v[after].min()), bool(np.all(np.isfinite(v))))


def t90(t: np.ndarray, y: np.ndarray, t0: float) -> float:
    """Time after t0 until y first covers 90 % of its total change."""
    y0 = y[np.searchsorted(t, t0) - 1]
    dy = y[-1] - y0
    k = np.nonzero((t > t0) & (np.abs(y - y0) >= 0.9 * abs(dy)))[0]
    return float(t[k[0]] - t0) if len(k) else float("nan")
