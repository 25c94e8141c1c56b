"""Li-ion batteries on the turbines' DC links: capacity, state of charge, OCV(SOC), resistance, limits.

One battery per turbine (arrays over the N turbines), in parallel with the DC capacitor where
``TurbineBank.battery`` is on (``Plant.set_battery``); the paper's "2000 Ah Li-ion battery".
Parameters: plant.params.BatteryParams (capacity, SOC window, C-rate limits, cell data);
quantities in p.u. of the DC base (v_dc = 1 at ``TurbineParams.v_dc_base_kv``, power on the
turbine rating, current base I_b = S_rated / V_dc,base, resistance base V_dc,base^2 / S_rated).

Cell open-circuit voltage: the static part (no current, no filtered current) of the modified
Shepherd model of Tremblay & Dessaint (2009), with the charge removed it = (1 - SOC) Q_c::

    E_cell(SOC) = E0 - K (1 - SOC)/SOC + A exp(-B Q_c (1 - SOC))
    A = V_full - V_exp,  B = 3 / Q_exp,  K = (V_full - V_nom + A (exp(-B Q_nom) - 1)) (Q_c - Q_nom) / Q_nom,
    E0 = V_full + K + R_c i_fit - A                          (the model's fit to three datasheet points)

Aggregated units: a converter of n turbines' rating (the 40 MVA onshore unit, n = 4) carries n packs,
the aggregation rule of ``PlantParams.onshore_unit_mva`` (n identical units in parallel are one unit of
n times the rating with the same p.u. values): the p.u. constants below are every converter's, and its
energy in MWh is counted on its own rating (``energy_mwh``; on the turbine's 10 MVA it was 4x too small
for the onshore unit). [assumed: the paper's "a 2000 Ah Li-ion battery" for the aggregated SDViSC
read per turbine converter; one 2000 Ah pack for the whole 40 MVA unit would be 1/4 of these p.u.
capacity and current limits.]

Pack: n_p = capacity / Q_c cells in parallel, n_s in series with n_s E_cell(SOC_init) = v_dc_ref
V_dc,base (the battery floats on the DC link at the initial SOC: no current at rest)::

    OCV(SOC) = n_s E_cell(SOC) / V_dc,base,   r_b = (n_s R_c / n_p) / Z_dc,base,   Q = capacity / I_b  (p.u. x s)
    i_b = clip((OCV(SOC) - v_dc) / r_b, -i_chg,max, i_dis,max)   (C-rate limits; + = discharging)
    i_b = 0 where discharging at SOC <= SOC_min or charging at SOC >= SOC_max
    P_batt = v_dc i_b                                          (into the DC link, turbine.py)
    dSOC/dt = -i_b / Q                                          (coulomb counting)

The SOC changes by at most 4.5 C x 0.67 ms = 8e-7 per step: it is not part of the fast state but
updated once per plant step (``count``, forward Euler on the battery current of the step's first
stage, which ``Plant.step`` has evaluated anyway) and held within the step (the numpy and the
compiled path alike: ``after_step`` gives the next step's SOC before the step is taken, the
compiled step evaluates its second stage at the held SOC and the state it reaches at the next
one). The error of that
against the exact charge is below h/2 |di_b| / Q per step (|di_b| the current's change over the
step), i.e. < 1e-6 SOC over a whole transient; a constant current is counted exactly. The SOC
limits act on the SOC at the step's start, so a limit is passed by at most i_max h / Q (< 1e-6).

With the pack resistance (0.032 p.u. for 2000 Ah) the battery adds the pole -1/(tau_dc r_b)
(-3850 /s) to the DC link: h lambda = -2.6, outside Heun's stability interval; ``dc_link_pole``
gives it to the ETD2 linear split (plant/sim.py ``_coefficients``), like the current-loop pole.
"""

from __future__ import annotations

import numpy as np

from plant import turbine_laws as laws
from plant.params import BatteryParams, TurbineParams


class BatteryBank:
    """The N turbines' batteries: derived pack constants, SOC and delivered energy per turbine."""

    def __init__(self, bp: BatteryParams, tp: TurbineParams, n: int, rating_mva=None):
        self.p = bp
        v_base = tp.v_dc_base_kv * 1e3  # V
        i_base = tp.s_rated_mva * 1e6 / v_base  # A
        a = bp.cell_v_full - bp.cell_v_exp
        b = 3.0 / bp.cell_q_exp
        k = ((bp.cell_v_full - bp.cell_v_nom + a * (np.exp(-b * bp.cell_q_nom) - 1.0))
             * (bp.cell_q - bp.cell_q_nom) / bp.cell_q_nom)
        self._cell = (bp.cell_v_full + k + bp.cell_r * bp.cell_i_fit - a, k, a, b * bp.cell_q)  # E0, K, A, B Q_c
        self.n_series = tp.v_dc_ref * v_base / float(self.cell_ocv(bp.soc_init))
        self.n_parallel = bp.capacity_ah / bp.cell_q
        self.r = self.n_series * bp.cell_r / self.n_parallel / (v_base**2 / (tp.s_rated_mva * 1e6))  # p.u.
        self.q = bp.capacity_ah * 3600.0 / i_base  # p.u. current x s
        self.i_dis_max = bp.c_rate_discharge * bp.capacity_ah / i_base  # p.u.
        self.i_chg_max = bp.c_rate_charge * bp.capacity_ah / i_base
        self.ocv_scale = self.n_series / v_base
        self.s_turbine_mva = float(tp.s_rated_mva)
        # each converter's own rating (the onshore unit: 40 MVA): its p.u. energy is on that base
        self.s_rated_mva = np.broadcast_to(np.asarray(tp.s_rated_mva if rating_mva is None else rating_mva,
                                                      dtype=float), (n,)).copy()
        self.soc = np.full(n, float(bp.soc_init))
        self.energy = np.zeros(n)  # delivered to the DC link since the start, p.u. x s (turbine rating)

    def cell_ocv(self, soc):
        """E_cell(SOC), V (Tremblay-Dessaint, no current)."""
        return laws.cell_ocv(soc, *self._cell)

    def cell_constants(self) -> tuple[float, float, float, float]:
        """(E0, K, A, B Q_c): the constants of ``turbine_laws.cell_ocv``."""
        return self._cell

    def ocv(self, soc):
        """Pack open-circuit voltage, p.u. of the DC base."""
        return self.ocv_scale * self.cell_ocv(soc)

    def current(self, vdc, on):
        """Battery current into the DC link (p.u., + = discharging) of the turbines where ``on``."""
        return laws.battery_current(self.ocv(self.soc), vdc, self.soc, on, *self.current_constants())

    def current_constants(self) -> tuple[float, float, float, float, float]:
        """(r_b, i_dis_max, i_chg_max, soc_min, soc_max): the constants of ``turbine_laws.battery_current``."""
        return self.r, self.i_dis_max, self.i_chg_max, self.p.soc_min, self.p.soc_max

    def dc_link_pole(self, tau_dc: float) -> float:
        """c = 1/(tau_dc r_b): minus the battery's eigenvalue of w = v_dc^2 at v_dc = OCV, 1/s."""
        return 1.0 / (tau_dc * self.r)

    def after_step(self, i, vdc, h: float):
        """(SOC, delivered energy) after one step h (s) at battery current i (p.u.): new arrays;
        ``Plant`` stores them when it has taken the step."""
        return self.soc - i * (h / self.q), self.energy + vdc * i * h

    def energy_mwh(self):
        """Delivered energy per converter, MWh: p.u. x s on the converter's own rating."""
        return self.energy * (self.s_rated_mva / 3600.0)

    def capacity_ah(self):
        """Pack capacity per converter, Ah: ``capacity_ah`` per turbine converter, a unit of n turbines'
        rating aggregated with n packs (the aggregation rule of ``PlantParams.onshore_unit_mva``: the same
        p.u. values on n times the rating), so the p.u. constants above hold for every converter."""
        return self.p.capacity_ah * self.s_rated_mva / self.s_turbine_mva
