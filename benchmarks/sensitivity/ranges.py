"""The sourced parameter ranges of the claim sensitivity study (issue 28, build item 10), tried one at
a time at each end (``RANGE`` rows, which may go into the best corner), and the open choices of
values the paper leaves open (``OPEN`` rows, never in the corner). The structural alternatives of
issue 39 (plant controller, Q limitation, delay, step vs ramp, bus, fault type) are in
benchmarks/sensitivity/structure.py."""

from __future__ import annotations

from benchmarks.sensitivity.common import OPEN, Param

AMBIGUITY = OPEN


def pll(kp: float, ki: float) -> dict:
    return {"turbine.kp_pll": kp, "turbine.ki_pll": ki}


# ------------------------------------------------------------------------------------ the parameters
# Sources: Kundur, Power System Stability and Control (1994), Table 4.2 (typical synchronous machine
# parameters, thermal units: x''d 0.12-0.25, x'd 0.15-0.4, T'd0 3-10 s, T''d0 0.02-0.05 s);
# IEC 60076-5 Table 1 (recognised minimum short-circuit impedance of two-winding transformers: 8 %
# for 6.3-25 MVA, 10 % for 25-40 MVA); VDE-AR-N 4120:2018 (FRT k = 2, range 2-6); ENTSO-E RfG
# (EU 2016/631) Art. 21(3)(d) (voltage-control slope 2-7 %, 90 % of a step within 1-5 s) and
# Art. 25(5) Table 9 (total Q/P_max range 0.5-0.95 by synchronous area); IEEE C62.92 / IEC 60071-1
# (effectively grounded: X0/X1 <= 3); the paper's own values where it prints several.
SC_XD2 = Param("SC x''d", {"0.12": {"condenser.xd2": 0.12}, "0.25": {"condenser.xd2": 0.25}}, "0.20",
               "Kundur Table 4.2, thermal units 0.12-0.25 (PARAMETERS.md: 0.20 typical)")
SC_XD1 = Param("SC x'd", {"0.25": {"condenser.xd1": 0.25}, "0.40": {"condenser.xd1": 0.40}}, "0.30",
               "Kundur Table 4.2, 0.15-0.4; low end 0.25 to stay above x''d = 0.20")
SC_XD = Param("SC x_d", {"1.0": {"condenser.xd": 1.0, "condenser.xq": 0.95},
                         "2.3": {"condenser.xd": 2.3, "condenser.xq": 2.2}}, "1.8 (x_q 1.7)",
              "Kundur Table 4.2, thermal units x_d 1.0-2.3 (x_q moved with it)")
SC_TD01 = Param("SC T'd0", {"3 s": {"condenser.td01": 3.0}, "10 s": {"condenser.td01": 10.0}}, "7 s",
                "Kundur Table 4.2, 3-10 s")
SC_TD02 = Param("SC T''d0", {"0.02 s": {"condenser.td02": 0.02}, "0.05 s": {"condenser.td02": 0.05}}, "0.04 s",
                "Kundur Table 4.2, 0.02-0.05 s")
SC_XTR = Param("SC step-up x", {"0.10": {"condenser.x_tr": 0.10}, "0.15": {"condenser.x_tr": 0.15}}, "0.12",
               "IEC 60076-5 Table 1: at least 10 % for 25-40 MVA; 15 % the usual upper end of large step-ups")
SC_H = Param("SC H", {"1.0 s": {"condenser.h": 1.0}, "2.0 s": {"condenser.h": 2.0}}, "1.2 s",
             "[assumed] condensers without flywheel 1-2 s (PARAMETERS.md: 1.2 typical)")
SC_AVR_K = Param("SC AVR gain K", {"100": {"condenser.avr_k": 100.0}, "400": {"condenser.avr_k": 400.0}}, "200",
                 "[assumed] static exciters 100-400 around Kundur's two-area SEXS K = 200")
SC_AVR_BUS = Param("SC AVR senses", {"PCC": {"condenser.avr_bus": "pcc"}}, "its terminal",
                   "the paper: 'AVR droop 0.02', bus not stated (IEEE 421.5: the terminal)", AMBIGUITY)
PLL = Param("PLL bandwidth", {"47 rad/s": pll(0.15, 3.6), "157 rad/s": pll(0.5, 40.0)}, "79 rad/s (k_p 0.25, k_i 10)",
            "[assumed] grid-following PLLs 7.5-25 Hz; damping ratio 0.7 kept: k_i = (w0 k_p / (2 zeta))^2 / w0")
FRT = Param("FRT k", {"2": {"turbine.frt_k_qv": 2.0}, "6": {"turbine.frt_k_qv": 6.0}}, "2",
            "VDE-AR-N 4120:2018: k = 2 default, 2-6 allowed")
WPP_KI = Param("plant controller k_i", {"2": {"wpp.k_i": 2.0}, "10": {"wpp.k_i": 10.0}}, "10 (t90 ~ 1 s)",
               "ENTSO-E RfG Art. 21(3)(d)(iv): 90 % of a step within 1-5 s, i.e. k_i 10 (1 s) down to 2 (5 s)")
WPP_DROOP = Param("plant controller droop", {"0.02": {"wpp.droop": 0.02}, "0.07": {"wpp.droop": 0.07}}, "0.04",
                  "ENTSO-E RfG Art. 21(3)(d): slope 2-7 %")
WPP_QMAX = Param("plant controller Q limit", {"0.25": {"wpp.q_max": 0.25}, "0.475": {"wpp.q_max": 0.475}},
                 "0.33 (pf 0.95)", "ENTSO-E RfG Art. 25(5) Table 9: total Q/P_max range 0.5-0.95, i.e. +-0.25 to +-0.475")
WPP_OFF = Param("plant voltage controller", {"off (unity-pf farm)": {"wpp.enabled": False}}, "in service",
                "the paper does not mention one (its farm is CIGRE C4.49's, whose plant controls the PCC)", AMBIGUITY)
X_TTR = Param("turbine transformer x", {"0.08": {"grid.x_ttr": 0.08}, "0.10": {"grid.x_ttr": 0.10}}, "0.08",
              "IEC 60076-5 Table 1: at least 8 % for 6.3-25 MVA (11 MVA); 10 % a usual upper value")
X_ONSHORE = Param("SDViSC step-up x", {"0.10": {"plant.x_onshore_step_up": 0.10},
                                       "0.15": {"plant.x_onshore_step_up": 0.15}}, "0.12",
                  "IEC 60076-5 Table 1: at least 10 % for 25-40 MVA; 15 % the usual upper end")
K0 = Param("grid Z0/Z1", {"0.5": {"grid.k0_grid": 0.5}, "3.0": {"grid.k0_grid": 3.0}}, "1.0",
           "[assumed] 0.5 (a bus with several grounded-star transformers) to 3 (IEEE C62.92 / IEC 60071-1: "
           "effectively grounded X0/X1 <= 3)")
V_STAR = Param("SDViSC V*", {"1.00": {"visc.v_ref": 1.0}, "1.04": {"visc.v_ref": 1.04}}, "1.00",
               "the paper's own AVR references (Fig. Compare_Volg: 1.00 -> 1.04)")
VISC_D = Param("SDViSC D", {"50": {"visc.d": 50.0}, "130": {"visc.d": 130.0}}, "90 (zeta 0.7)",
               "[assumed] PARAMETERS.md: D for a swing-mode damping ratio ~0.7; zeta 0.4-1.0 gives D 50-130")
VISC_H = Param("SDViSC H", {"3 s": {"visc.h": 3.0}, "5 s": {"visc.h": 5.0}}, "3 s", "the paper's H values (3, 4, 5 s)")
VISC_KIV = Param("SDViSC K_iv", {"5": {"visc.k_iv": 5.0}, "20": {"visc.k_iv": 20.0}}, "20 (T_v 0.05 s)",
                 "not a sourced range: the paper varies T_v = 1/K_iv (Fig. Compare_Volg (b)) without printing its "
                 "values, and no published range was found; 5 and 20 are the values report F3 runs", AMBIGUITY)
VISC_KPV = Param("SDViSC K_pv", {"0.25": {"visc.k_pv": 0.25}, "1.0": {"visc.k_pv": 1.0}}, "0.5",
                 "[assumed] a factor 2 around PARAMETERS.md's example 0.5 (no published value)")
VISC_LV = Param("SDViSC L_vir", {"0.1": {"visc.l_v": 0.1}, "0.3": {"visc.l_v": 0.3}}, "0.2",
                "[assumed] +-50 % around D'Arco 2015's 0.2 p.u.")
VISC_MQ = Param("SDViSC m_q", {"0.02": {"visc.m_q": 0.02}, "0.10": {"visc.m_q": 0.10}}, "0.02",
                "the paper's droops (0.02 comparison, 0.03-0.10 parallel)")

F6D_PARAMS = (X_ONSHORE, X_TTR, K0, FRT, VISC_LV)  # the fault resistance: the fault matrix (structure.py)
F7_PARAMS = (SC_XD2, SC_XD1, SC_XD, SC_TD01, SC_TD02, SC_XTR, SC_H, SC_AVR_K, PLL, FRT, WPP_KI, WPP_DROOP, WPP_QMAX)
# SC_AVR_BUS and the plant controller's structure: structure.F7_STRUCTURE
F8_SCR = Param("SCR of the case", {"4.0": {"case.scr": 4.0}, "3.0": {"case.scr": 3.0}}, "7.14",
               "not printed for Fig. study2_VSC_reg (its Fig. Compare_ShortC says 7.14); the farm alone is stable "
               "above ~2.1 (F7.a)", AMBIGUITY)
F8_OPEN = Param("open choices together", {
    "SCR 4.0, no plant controller": {"case.scr": 4.0, "wpp.enabled": False},
    "SCR 3.0, no plant controller": {"case.scr": 3.0, "wpp.enabled": False},
    "SCR 3.0, no plant controller, V* 1.04": {"case.scr": 3.0, "wpp.enabled": False, "visc.v_ref": 1.04},
    "SCR 2.5, no plant controller, V* 1.04": {"case.scr": 2.5, "wpp.enabled": False, "visc.v_ref": 1.04}},
    "SCR 7.14, plant controller in service, V* 1.00",
    "the SCR and the plant controller as above; V* at the paper's 1.04 with them", AMBIGUITY)
F8_WPP_ON = Param("plant voltage controller", {"in service (PCC voltage control)": {"wpp.enabled": True}},
                  "reactive-power mode at Q* = 0 (unity-pf farm), as report F8: the paper's 0.97 is 'below the "
                  "rated voltage', a farm not regulating its PCC", "the paper does not mention one", AMBIGUITY)
F8_PARAMS = (V_STAR, WPP_QMAX, WPP_DROOP, X_TTR, K0, FRT, PLL, F8_SCR, F8_WPP_ON, F8_OPEN)
F9_PARAMS = (VISC_D, VISC_H, VISC_KIV, VISC_KPV, VISC_LV, VISC_MQ, PLL, FRT, WPP_KI, WPP_DROOP, WPP_QMAX)
# virtual friction and the plant controller's structure: structure.F9_STRUCTURE
C1_PRODUCING = Param("plugged turbine before the plug", {"at P = 0": {"case.p_before_zero": True}},
                     "producing (as the network scenario)", "the paper does not say; its ViSC has T_m = 0", AMBIGUITY)
C1_PARAMS = (VISC_H, VISC_D, VISC_KIV, VISC_KPV, VISC_LV, FRT, PLL, WPP_KI, C1_PRODUCING, WPP_OFF)
