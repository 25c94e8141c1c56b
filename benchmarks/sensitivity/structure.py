"""The structural alternatives of issue 39 ("the sensitivity study redone over structure as well as
values"): the plant controller's model, its Q limitation, communication delay and gain rule, step vs
ramp, the SC's AVR bus, virtual friction (F7, F9); the bus, fault type, fault resistance and reading
(F6.d, F8.c: the fault matrix of benchmarks/sensitivity/faults.py). Every alternative is an ``OPEN``
row: tried one at a time against the default, never combined into the best corner; a printed number
only such an alternative reaches is "consistent", not reproduced. Each carries its source or
"[assumed: reason]"."""

from __future__ import annotations

import math

from benchmarks.sensitivity.common import OPEN, Param

SCR_DEFAULT = 7.14  # the paper's SCR before the weak-grid step (Fig. Compare_ShortC)
KI_DEFAULT = 10.0  # WppParams.k_i [src: Dynawo's IEC 61400-27-1 WPP test, Kiwpx = 10]
KI_PER_SCR = KI_DEFAULT / SCR_DEFAULT  # k_i = KI_PER_SCR x SCR (x (SCR/7.14)^(p-1) with case.ki_power p)
KI_RULE = (f"k_i = {KI_DEFAULT:g} x (SCR/{SCR_DEFAULT:g})^p at the run's post-event SCR, so that the integral loop's "
           "crossover k_i dV/dq (and its phase margin against the 0.1 s cycle + 0.1 s delay) stays the default's at SCR "
           "7.14 (an operator's re-tuning for the weak grid, not a sourced value). p = 1: the short-circuit-power rule "
           "(dV_pcc/dq ~ S_farm/S_k ∝ 1/SCR: k_i 2.1 at SCR 1.51, within the 2-10 ENTSO-E RfG Art. 21(3)(d)(iv)'s 1-5 s "
           "to 90 % allows); p = 2 [assumed: the farm's gain dV_pcc/dq from the load flow (turbines as PQ sources, "
           "+-0.01 order) rises faster than 1/SCR: 0.250 at 7.14, 0.329 at 6, 0.468 at 5, 0.980 at 4.0 (x3.9 where "
           "1/SCR gives x1.8 and 1/SCR^2 x3.2), no static solution below ~3.6, so the rule is extrapolated]; k_i 0.45 "
           "at SCR 1.51, below the RfG range (t90 > 5 s)")

WPP_MODEL = Param("plant controller model", {
    "legacy (before issue 39)": {"wpp.legacy": True},
    "off (no plant controller, turbines at unity pf)": {"wpp.enabled": False},
    "IEC, no dip freeze": {"wpp.u_dip": 0.0, "wpp.u_release": 0.0},
    "IEC, reactive-power mode Q* = 0": {"wpp.mode": "reactive_power", "wpp.q_ref": 0.0},
}, "IEC 61400-27-1 voltage control (plant/wpp.py: 0.1 s cycle, filters 0.01 s, lag 0.1 s, rate 10/s, delay 0.1 s, "
   "dip freeze 0.8/0.9, Q limitation 1.05 -> 1.1)",
    "legacy: plant.wpp.legacy_params (the project's controller before issue 39: no cycle, filter, delay, freeze or "
    "Q limitation; not a published model); off: the paper does not mention a plant controller [the CIGRE C4.49 "
    "farm's plant controls its PCC]; no dip freeze: [assumed: a plant controller without IEC's FRT freeze "
    "(u_WPqdip, Dynawo test 0.8)]; Q mode: IEC 61400-27-1 M_WPqmode 0 at Q* = 0 (report F8's reading of the "
    "paper's 'PCC 0.97, below the rated voltage')", OPEN)
Q_LIMIT = Param("turbine Q limitation (over-voltage)", {
    "none up to 1.2 (Dynawo example table = off here)": {"wpp.u_qlim_knee": math.inf, "wpp.u_qlim_zero": math.inf},
    "line 1.1 -> 1.2": {"wpp.u_qlim_knee": 1.1, "wpp.u_qlim_zero": 1.2},
}, "[assumed] line: q_max up to 1.05 p.u. at the terminal, 0 at 1.1",
    "Dynawo's IEC example (Params_QLimit.mo: tableQMaxuWTCfilt = [0,0; 0.001,0; 0.8,0.33; 1.2,0.33]) has no "
    "over-voltage reduction up to 1.2 p.u.: in this model's one-segment limitation that is the same run as no "
    "limitation at all (its under-voltage part below 0.8 p.u. is not modelled: there the turbines are in FRT and "
    "the plant controller frozen); line 1.1 -> 1.2: [assumed: the reduction starting only at the 1.1 p.u. "
    "continuous-operation limit]; the ENTSO-E RfG U-Q/Pmax profile narrows the capacitive range at high voltage "
    "without fixing a line (the TSO chooses it)", OPEN)
COMM_DELAY = Param("plant controller communication delay", {
    "0.05 s": {"wpp.comm_delay_s": 0.05}, "0.2 s": {"wpp.comm_delay_s": 0.2}}, "0.1 s",
    "[assumed: the 0.05-0.2 s issue 39 names for plant-to-turbine communication; IEC 61400-27-1's communication "
    "module is project-dependent]", OPEN)
KI_RETUNED = Param("plant controller k_i re-tuned for the SCR", {
    "k_i = 10 x SCR/7.14": {"case.ki_per_scr": KI_PER_SCR},
    "k_i = 10 x (SCR/7.14)^2": {"case.ki_per_scr": KI_PER_SCR, "case.ki_power": 2.0}}, "10 at every SCR", KI_RULE, OPEN)
STEP_RAMP = Param("SCR change: step vs slow ramp", {
    "ramp 0.025/s (IEC)": {"case.ramp": True},
    "ramp 0.025/s (legacy controller)": {"case.ramp": True, "wpp.legacy": True},
    "ramp 0.025/s (no Q limitation)": {"case.ramp": True, "wpp.u_qlim_knee": math.inf, "wpp.u_qlim_zero": math.inf},
}, "a step 7.14 -> SCR at 1 s (the paper: 'when the SCR decreases to')",
    "the paper does not say how its RTDS lowers the SCR; the ramp is report/f7_mechanism.py's (a step to 4.0, then "
    "0.025 SCR/s: quasi-static against the plant controller's ~1 s): report/f7_second_look.ramp_boundary for the "
    "default and legacy controllers, f7_mechanism.ramp_run on the changed plant otherwise", OPEN)
SC_AVR_BUS = Param("SC AVR senses", {"PCC": {"condenser.avr_bus": "pcc"}}, "its terminal",
                   "the paper: 'AVR droop 0.02', bus not stated (IEEE 421.5: the terminal; the PCC as a plant-level "
                   "voltage regulator would)", OPEN)
FRICTION = Param("virtual friction (eq. 4)", {"on (sign as sdc_unit after the damping analysis)": {"visc.supp": True}},
                 "off (report VIRTUAL_FRICTION_DEFAULT)", "the paper designs it for weak grids; not said whether its "
                 "Figs. Compare_Weak / study2_Weak_noVSC use it; gains PARAMETERS.md's [assumed]", OPEN)

F7_STRUCTURE = (WPP_MODEL, Q_LIMIT, COMM_DELAY, KI_RETUNED, STEP_RAMP, SC_AVR_BUS, FRICTION)
F9_RAMP = Param("SCR change: step vs slow ramp", {"ramp 0.025/s to 1.51 (IEC)": {"case.ramp": True}},
                "a step 7.14 -> 1.51 at 1 s (the paper's)",
                "the paper: 'the SCR is changed from 7.14 to 1.51 at 1 s' — a step; the ramp (a step to 4.0, then "
                "0.025 SCR/s down to 1.51, held 4 s) shows whether the result depends on the jump; F9.d is then the "
                "time from reaching 1.51, plus 1 s (comparable with the paper's event at 1 s)", OPEN)
F9_STRUCTURE = (WPP_MODEL, Q_LIMIT, COMM_DELAY, KI_RETUNED, F9_RAMP, FRICTION)

# ------------------------------------------------------------------ the fault matrix (F6.d, F8.c)
FAULT_KINDS = ("slg", "llg")  # plant/network.py FAULT_KINDS: single phase (a) / two phases (b, c) to ground
FAULT_KIND_SOURCE = ("the paper: F6 'single-phase-to-ground fault', F8 'a phase-to-ground fault at the grid side' "
                     "(read as single phase; LLG the other reading issue 39 names) [LLG: an open choice]")
R_F_OHM = (0.0, 15.0, 50.0)
R_F_SOURCE = ("report/fault_readings.py R_F_RANGE_OHM: 0 at the source, 15 ohm on a line with ground wires, 50 ohm "
              "without [src: ebrary.net/84198]; at the 400 kV PCC [assumed: report V_PCC_KV]; the paper does not state "
              "it: a value reached only through it is 'consistent'")
READING_SOURCE = ("the paper's figures are RTDS plots of 'the voltage' without a sequence or bus: the positive "
                  "sequence V1, the faulted phase('s mean), the lowest phase, the three-phase RMS; at the device's "
                  "terminal (behind its step-up, YNd1: V1 at -30 deg, V2 at +30 deg, no V0 [assumed: as the SC's]) "
                  "or at the PCC")
