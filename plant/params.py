"""Plant parameters: values only, no equations.

Every field documents its unit, default and source tag:
[paper] the SDViSC paper, [src: ...] a published source (see
/work/shared/reference/PARAMETERS.md), [assumed] engineering judgement.

Bases: the network is per-unit on ``GridParams.s_base_mva`` (500 MVA); turbine
quantities are per-unit on the turbine rating (``TurbineParams.s_rated_mva``,
0.69 kV); the condenser on its own rating.  Voltage bases are the nominal
voltages of each bus, so a voltage in p.u. is the same number on every power base.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from sdvisc.vocabulary import FILTER_R_F_PU, FILTER_X_F_PU


@dataclass
class GridParams:
    """Onshore grid, export system and collector (network base)."""

    s_base_mva: float = 500.0
    """Network power base, MVA [paper]."""
    scr: float = 7.14
    """Short-circuit ratio at the PCC on ``s_base_mva`` (|Z_grid| = 1/SCR p.u.), 7.14 strong [paper]."""
    r_over_x: float = 0.1
    """Grid Thevenin R/X, - [paper]."""
    e_grid: float = 1.0
    """Grid source EMF magnitude, p.u. [assumed]; lower it to reproduce an undervoltage case."""
    h_grid: float = 0.0
    """Grid source inertia on ``s_grid_mva``, s; 0 = ideal (infinite) source [assumed; H = 5 s suggested]."""
    s_grid_mva: float = 3570.0
    """Rating of the finite-inertia grid source, MVA [assumed: = SCR x 500 MVA]."""
    d_grid: float = 1.0
    """Grid source load-damping, p.u. power / p.u. speed on ``s_grid_mva`` [assumed]."""
    r_gov: float = 0.05
    """Grid governor droop, p.u. speed / p.u. power [assumed]; only with h_grid > 0."""
    t_gov: float = 5.0
    """Grid governor/turbine time constant, s [assumed]."""
    k0_grid: float = 1.0
    """Grid zero-sequence to positive-sequence impedance ratio Z0/Z1, - [assumed]."""
    # collector / substation / export system (network base unless noted)
    r_ttr: float = 0.005
    """Turbine transformer resistance on its rating, p.u. [assumed]."""
    x_ttr: float = 0.08
    """Turbine transformer 0.69/66 kV leakage reactance on its rating, p.u. [src: PARAMETERS.md, assumed]."""
    s_ttr_mva: float = 11.0
    """Turbine transformer rating, MVA [src: PARAMETERS.md, assumed]."""
    array_km: float = 5.0
    """Equivalent length of one cluster's aggregated 66 kV string cable, km [assumed]."""
    array_r_ohm_km: float = 0.04
    """66 kV array cable resistance, ohm/km [src: WISDEM/ORBIT 630 mm2 XLPE]."""
    array_l_mh_km: float = 0.35
    """66 kV array cable inductance, mH/km [src: WISDEM/ORBIT]."""
    array_c_nf_km: float = 300.0
    """66 kV array cable capacitance, nF/km [src: WISDEM/ORBIT]."""
    v_array_kv: float = 66.0
    """Collector voltage, kV [paper]."""
    x_otr: float = 0.14
    """Offshore 66/220 kV transformer reactance on its rating, p.u. [src: PARAMETERS.md, assumed]."""
    r_otr: float = 0.003
    """Offshore transformer resistance on its rating, p.u. [assumed]."""
    s_otr_mva: float = 600.0
    """Offshore transformer rating, MVA [assumed]."""
    v_export_kv: float = 220.0
    """Export cable voltage, kV [assumed, PARAMETERS.md]."""
    export_km: float = 50.0
    """Export cable length, km [assumed]."""
    export_r_ohm_km: float = 0.03
    """Export cable resistance, ohm/km [assumed, typical 220 kV 1000 mm2]."""
    export_l_mh_km: float = 0.40
    """Export cable inductance, mH/km [assumed, typical]."""
    export_c_nf_km: float = 190.0
    """Export cable capacitance, nF/km [src: PARAMETERS.md / ORBIT]."""
    export_sections: int = 3
    """Number of pi-sections of the export cable, - [assumed]."""
    comp_fraction: float = 0.5
    """Fraction of the export cable charging compensated by shunt reactors (half at each end), - [assumed]."""
    x_ontr: float = 0.12
    """Onshore 220/400 kV transformer reactance on its rating, p.u. [assumed]."""
    r_ontr: float = 0.003
    """Onshore transformer resistance on its rating, p.u. [assumed]."""
    s_ontr_mva: float = 600.0
    """Onshore transformer rating, MVA [assumed]."""


@dataclass
class TurbineParams:
    """One PMSG full-converter turbine (p.u. on its rating unless noted)."""

    s_rated_mva: float = 10.0
    """Turbine rating, MVA (= MW at unity pf) [paper]."""
    v_rated_kv: float = 0.69
    """Converter terminal voltage, kV [brief]."""
    lf: float = FILTER_X_F_PU
    """Filter inductance, p.u. [src: D'Arco, Suul, Fosso EPSR 2015]."""
    rf: float = FILTER_R_F_PU
    """Filter resistance, p.u. [src: D'Arco 2015]."""
    cf: float = 0.074
    """Filter capacitance (shunt at the terminal, quasi-static), p.u. [src: D'Arco 2015]."""
    kpc: float = 1.27
    """Current-controller proportional gain, p.u. voltage / p.u. current [src: D'Arco 2015]."""
    kic: float = 14.3
    """Current-controller integral gain, p.u. voltage / (p.u. current * s) [src: D'Arco 2015 value; time in s assumed]."""
    i_max_gfl: float = 1.1
    """Grid-following current limit (circular), p.u. [assumed]."""
    frt_v_dip: float = 0.9
    """Fault ride-through: terminal voltage (PLL-frame V_d) below which additional reactive current is
    injected, p.u. [src: IEC 61400-27-1 u_qdip = 0.9 (voltage-dip threshold of the Type 4 generic
    model's Q control); VDE-AR-N 4120 dead band 10 %]."""
    frt_k_qv: float = 2.0
    """Fault ride-through gain k: additional reactive current per p.u. voltage below ``frt_v_dip``,
    reactive-current priority while it acts; 0 disables FRT, p.u./p.u. [src: VDE-AR-N 4120:2018 / the
    German grid code's default k = 2 (range 2-6); IEC 61400-27-1 K_qv]."""
    t_ufilt: float = 0.01
    """Voltage measurement filter of the converter controls (|v| seen by P*/V and the FRT), s
    [src: IEC 61400-27-1 Type 4 "T_ufilt"; 0.01 s in Dynawo's WT4B example parameter set
    (Examples/Wind/IEC/Neplan/WT4BCurrentSource2015.mo, with K_qv = 2 as here)]."""
    k_ad: float = 0.2
    """Active damping gain of the current loop: v_conv -= k_ad (v - phi), p.u./p.u. [paper: "an additional
    active damping controller, which ... suppresses filter voltage oscillations" (Section II); value:
    D'Arco, Suul, Fosso EPSR 2015 as parameterised in PowerSimulationsDynamics.jl's D'Arco inverter
    (k_ad 0.2)]. Without it the filter capacitor rings at ~725 Hz with the dynamic-phasor network."""
    w_ad: float = 50.0
    """Active damping's low-pass cut-off, rad/s [src: same as k_ad (omega_ad 50 rad/s)]."""
    ext_active_damping: bool = True
    """The converter's active damping also under a ViSC's reference (hd_visc, remote), with either
    network model [paper, Section II: the ViSC's inner loop "includes ... an additional active damping
    controller"]. Before issue 39 item 10 it acted with the dynamic-phasor network only (there the onshore
    40 MVA SDViSC's filter rang at ~390 Hz and grew without it), so NM.F9 mixed two changes."""
    m_max: float = 1.15
    """Largest converter AC voltage per p.u. DC voltage (modulation limit), p.u./p.u. [assumed]."""
    kp_pll: float = 0.25
    """PLL proportional gain, p.u. speed / p.u. voltage (bandwidth ~ OMEGA0*kp = 79 rad/s) [assumed]."""
    ki_pll: float = 10.0
    """PLL integral gain, p.u. speed / (p.u. voltage * s) (zeta ~ 0.7) [assumed]."""
    tau_dc: float = 0.008
    """DC-link energy time constant C V_dc^2 / S_rated, s [src: PARAMETERS.md, assumed]."""
    v_dc_ref: float = 1.0
    """DC-link voltage reference, p.u. [assumed]."""
    kp_dc: float = 2.0
    """MSC DC-voltage PI proportional gain, p.u. power / p.u. voltage [src: PARAMETERS.md, assumed]."""
    ki_dc: float = 50.0
    """MSC DC-voltage PI integral gain, p.u. power / (p.u. voltage * s) [src: PARAMETERS.md, assumed]."""
    p_me_min: float = -0.05
    """Smallest machine-side power (motoring), p.u. [assumed]."""
    p_headroom: float = 0.1
    """MSC power allowed above the present aerodynamic power (rotor kinetic energy), p.u. [assumed]."""
    p_me_max: float = 1.1
    """Machine-side converter power rating, p.u. [assumed]."""
    h_rotor: float = 4.0
    """Single-mass drive train inertia (rotor + generator, stiff shaft), s [assumed]."""
    v_wind_rated: float = 11.4
    """Rated wind speed, m/s [assumed, IEA 10 MW class]."""
    omega_r_ref: float = 1.0
    """Rotor speed reference of the pitch controller, p.u. [assumed]."""
    kp_beta: float = 150.0
    """Pitch PI proportional gain, deg / p.u. speed [assumed]."""
    ki_beta: float = 25.0
    """Pitch PI integral gain, deg / (p.u. speed * s) [assumed]."""
    tau_beta: float = 0.1
    """Pitch servo time constant, s [src: PARAMETERS.md, assumed]."""
    rate_beta: float = 8.0
    """Pitch rate limit, deg/s [src: PARAMETERS.md, assumed]."""
    beta_max: float = 30.0
    """Largest pitch angle, deg [assumed]."""
    v_chop: float = 1.1
    """DC chopper (braking resistor) threshold, p.u. [assumed]."""
    k_chop: float = 5.0
    """DC chopper gain, p.u. power / p.u. overvoltage (max 1.5 p.u. power; 2 k/tau_dc = 1250 /s keeps the explicit step stable) [assumed]."""
    v_dc_base_kv: float = 1.1
    """DC-link voltage base (v_dc = 1 p.u.), kV [assumed: the DC voltage at which the modulation limit
    m_max = 1.15 is reached by sqrt(2) x 0.69 kV x 1.15 = 1.12 kV (space-vector PWM, linear range);
    1.1 kV is typical of 690 V back-to-back converters]. Used by the battery (plant/battery.py)."""
    remote_apply: str = "v_ref"
    """Remote mode applies "v_ref" (the received converter voltage reference, held) [brief] or "i_ref"
    (the received limited current reference through the converter's local current loop
    v_conv = v + (r_f + j l_f) i_ref + k_pc (i_ref - i), as plant.minimal does)."""
    trip_current: float = 2.0
    """Remote mode over-current protection: |i| above this trips the turbine back to grid-following, p.u. [assumed]."""
    i_max_local: float = 1.5
    """The converter's local current limit under a received voltage reference (remote, ``remote_apply``
    "v_ref"), p.u.; 0 disables it. A real converter clamps locally, within its own control period: its
    current controller saturates at the hardware's overcurrent capability (a grid-forming converter's
    current-limiting mode, e.g. Taul et al. 2019, which the paper cites for the law's circular limiter;
    RTDS/RSCAD converter models limit their current locally), with a hardware trip (``trip_current``)
    behind it. Here, decided once per plant step (``Commands._local_current_limit``,
    ``turbine_laws.remote_current_limit``): where the held v_ref would take the filter current above this
    within the step, the converter draws that current scaled to this magnitude instead [paper: the
    SDViSC's overcurrent capability 1.5 p.u., the law's ``i_max``]. Without it the SDC's limiter, a
    sample late, let the onshore SDViSC reach 1.755 p.u. through the network (F6net.a) and 2.07 p.u.
    offline with a trip (issue 39 item 11)."""
    remote_loss_fallback_s: float = 0.1
    """Remote mode: time without a new reference before falling back to grid-following, s [brief]."""


@dataclass
class WppParams:
    """The wind power plant's Q/V controller at the PCC (plant/wpp.py, after IEC 61400-27-1:2015
    Annex D's WPP reactive power control): one order for every grid-following farm turbine (p.u. on
    the turbine rating), limited per turbine by its Q limitation. Values marked [src: Dynawo test] are
    those of Dynawo's IEC 61400-27-1:2015 WPP test case (Examples/Wind/IEC/Neplan/
    WPP4ACurrentSource2015.mo), the public reference implementation of the standard's models."""

    enabled: bool = True
    """Plant-level voltage control in service [paper: the farm's turbines are the CIGRE C4.49
    benchmark's, whose plant controller regulates the PCC; IEC 61400-27-1 WPP control]."""
    mode: str = "voltage"
    """"voltage" (voltage control with reactive droop, IEC M_WPqmode 3 with K_WPqu = ``droop``) or
    "reactive_power" (Q_WP to ``q_ref``, M_WPqmode 0) [assumed: a transmission-connected farm
    regulates its PCC voltage; the paper's "before the deployment of SDViSC the PCC voltage is 0.97
    p.u." is read in issue 39 as a farm that does not — run the other mode to see it]."""
    v_ref: float = 1.0
    """PCC voltage reference, p.u. [assumed: nominal]."""
    q_ref: float = 0.0
    """Q reference of the reactive power mode, p.u. on the turbine rating [assumed: unity power factor]."""
    droop: float = 0.04
    """Reactive droop K_WPqu: V_pcc settles at v_ref - droop Q (Q of one turbine on its rating), p.u./p.u.
    [assumed: grid codes ask for a slope of 2-7 % of the reactive range; ENTSO-E RfG Art. 21(3)(d)]."""
    k_i: float = 10.0
    """Integral gain K_IWPx, p.u. Q / (p.u. V s) [src: Dynawo test, Kiwpx = 10; also about 1 s to 90 %
    of a voltage step at SCR 7.14, within the 1-5 s ENTSO-E RfG asks (Art. 21(3)(d)(iv))]."""
    k_p: float = 0.0
    """Proportional gain K_PWPx, p.u. Q / p.u. V [assumed: 0, an integral controller as before issue 39;
    K_PWPx is project-dependent (the Dynawo test's 0.5 is for its reactive power mode)]."""
    k_i_q: float = 1.0
    """Integral gain of the reactive-power mode, p.u. Q / (p.u. Q s) [assumed: the Q loop closes through
    the 0.1 s cycle, the 0.1 s lag and the 0.1 s delay (≈ 0.3 s in all): crossover 1 rad/s keeps ≈ 70°
    of phase margin, where the voltage mode's 10 made it oscillate at ≈ 0.6 Hz (issue 39's sensitivity
    study); IEC 61400-27-1 leaves K_IWPx project-dependent]."""
    k_p_q: float = 0.0
    """Proportional gain of the reactive-power mode [assumed: 0, an integral controller as the voltage mode]."""
    q_max: float = 0.33
    """Reactive limit of the order (both signs; also X_KIWPxmax, the integrator's), p.u. [src: ENTSO-E RfG
    / typical grid codes: Q/P_max = 0.33 at full power (power factor 0.95)]."""
    period_s: float = 0.1
    """Controller cycle T_s, s: the PI, lag and rate limit are evaluated at t0, t0 + T_s, ... whatever
    the plant's step [assumed: a plant controller's cycle is 10-100 ms; 0.1 s, the slow end; IEC
    61400-27-1 writes the WPP control in continuous time and gives none]. 0 = the controller before
    issue 39 (a cycle at every slow-term hold of the plant: 6.7 ms at the 0.67 ms step)."""
    t_ufilt_s: float = 0.01
    """Voltage measurement filter T_WPufiltq, s [src: Dynawo test, tWPUFiltQ = 0.01]."""
    t_qfilt_s: float = 0.01
    """Reactive power measurement filter T_WPqfiltq, s [src: Dynawo test, tWPQFiltQ = 0.01]."""
    t_xfv_s: float = 0.1
    """Lag of the reference transfer function T_xfv (lead T_xft = 0), s [src: Dynawo test, txfv = 0.1,
    txft = 0]."""
    dq_max_per_s: float = 10.0
    """Rate limit of the order dX_refmax (both signs), p.u./s [src: Dynawo test, DXRefMaxPu = 10]."""
    comm_delay_s: float = 0.1
    """Communication delay of the order to the turbines (transport delay), s [assumed: the middle of
    the 0.05-0.2 s issue 39 names for plant-to-turbine communication; IEC 61400-27-1's communication
    module is project-dependent]."""
    u_dip: float = 0.8
    """Voltage dip threshold u_WPqdip: below it (filtered V_pcc) the integrator and the output freeze,
    p.u. [src: Dynawo test, UwpqDipPu = 0.8]."""
    u_release: float = 0.9
    """The freeze ends when the filtered V_pcc is back at or above this (the FRT flag's hysteresis),
    p.u. [src: the end of the turbines' FRT state, ``TurbineParams.frt_v_dip`` = IEC u_qdip = 0.9]."""
    u_qlim_knee: float = 1.05
    """Turbine Q limitation (the standard's QLimitation, Q_max as a function of the terminal voltage):
    the capacitive limit is q_max up to this terminal voltage, p.u. [assumed: the upper end of the
    0.95-1.05 band in which a converter gives its full reactive range]."""
    u_qlim_zero: float = 1.1
    """... falling linearly to 0 at this terminal voltage and above, p.u. [assumed: the 1.1 p.u.
    continuous-operation limit of the turbine's terminals (IEC 61400-21 / grid codes' 0.9-1.1)]."""
    t_qlim_s: float = 0.05
    """Lag of the turbine's Q order through which the Q limitation acts, s [src: Dynawo test, tQord =
    0.05 (the Type 4 turbine's Q order lag)]."""


@dataclass
class CondenserParams:
    """40 MVAr synchronous condenser, p.u. on its own rating."""

    s_rated_mva: float = 40.0
    """Rating, MVA [paper]."""
    h: float = 1.2
    """Inertia constant, s [assumed, typical]."""
    d: float = 0.0
    """Mechanical damping, p.u. torque / p.u. speed [assumed]."""
    xd: float = 1.8
    """d-axis synchronous reactance, p.u. [assumed, typical]."""
    xq: float = 1.7
    """q-axis synchronous reactance, p.u. [assumed, typical]."""
    xd1: float = 0.30
    """d-axis transient reactance x'd, p.u. [assumed, typical]."""
    xd2: float = 0.20
    """Subtransient reactance x''d = x''q, p.u. [assumed, typical]."""
    td01: float = 7.0
    """T'd0, s [assumed, typical]."""
    td02: float = 0.04
    """T''d0, s [assumed, typical]."""
    tq02: float = 0.06
    """T''q0, s [assumed, typical]."""
    ra: float = 0.003
    """Armature resistance, p.u. [assumed, typical]."""
    x_tr: float = 0.12
    """Step-up transformer reactance on the SC rating, p.u. [src: IEC 60076-5 Table 1, at least 0.10 at
    25-40 MVA; 0.12 a typical 40 MVA generator step-up, inside the 0.10-0.15 of benchmarks/claim_sensitivity.py.
    PARAMETERS.md assumed 0.10, the standard's minimum; with it the SC's F3 terminal rise is 0.0313, -10.5 %
    of the paper's 0.035 (benchmarks/f3_sc_sensitivity.py), with 0.12 0.0324 (2026-12-04)]."""
    avr_k: float = 200.0
    """SEXS gain K, p.u./p.u. [src: Kundur two-area]."""
    avr_ta_tb: float = 0.1
    """SEXS TA/TB, - [src: Kundur two-area]."""
    avr_tb: float = 10.0
    """SEXS TB, s [src: Kundur two-area]."""
    avr_te: float = 0.1
    """SEXS TE, s [src: Kundur two-area]."""
    efd_max: float = 4.0
    """Field voltage ceiling, p.u. [src: Kundur two-area]."""
    efd_min: float = 0.0
    """Field voltage floor, p.u. [assumed]."""
    m_q: float = 0.02
    """AVR reactive droop (V = V_ref - m_q Q, Q on SC rating), p.u./p.u. [paper: 0.02]."""
    avr_bus: str = "terminal"
    """Bus whose voltage the AVR regulates: "terminal" (its own terminal with reactive droop m_q, as an
    exciter with reactive-current compensation does) or "pcc" [src: IEEE Std 421.5 (the AVR senses the
    generator terminal voltage, with load compensation); paper: "AVR droop coefficients are both 0.02"]."""


@dataclass
class BatteryParams:
    """Li-ion battery in parallel with a turbine's DC capacitor (plant/battery.py; one per turbine,
    switched by ``Plant.set_battery``). Cell values: the A123 ANR26650M1 (LiFePO4) parameter set of the
    generic battery model of Tremblay & Dessaint, "Experimental validation of a battery dynamic model
    for EV applications", World Electric Vehicle Journal 3 (2009), as printed in the MathWorks
    Specialized Power Systems "Battery" block documentation [src: Tremblay 2009 / MathWorks]."""

    capacity_ah: float = 2000.0
    """Pack capacity, Ah [paper: "a 2000 Ah Li-ion battery"]."""
    soc_init: float = 0.5
    """Initial state of charge, - [assumed: mid-range, room to discharge and to charge]. The series cell
    count is chosen so that OCV(soc_init) = v_dc_ref: at rest the battery floats on the DC link."""
    soc_min: float = 0.1
    """SOC below which discharging stops, - [assumed; the Tremblay model is validated for SOC 10-100 %]."""
    soc_max: float = 0.9
    """SOC above which charging stops, - [assumed: a usual 10-90 % window]."""
    c_rate_discharge: float = 4.5
    """Largest discharge current, C (multiples of capacity_ah per hour) [assumed: 4.5 C = 9 kA, the
    turbine's rated DC current 10 MVA / 1.1 kV, since the battery's power leaves through the grid-side
    converter; the A123 cells allow 30 C continuous]."""
    c_rate_charge: float = 4.5
    """Largest charge current, C [assumed, as c_rate_discharge; within the A123 cells' 5 C charge rating]."""
    cell_v_full: float = 3.7
    """Cell fully charged voltage (Tremblay: V_full), V [src: Tremblay 2009 / MathWorks, A123 ANR26650M1]."""
    cell_v_exp: float = 3.4
    """Cell voltage at the end of the exponential zone (V_exp), V [src: same]."""
    cell_q_exp: float = 0.23
    """Charge removed at the end of the exponential zone (Q_exp), Ah [src: same]."""
    cell_v_nom: float = 3.22
    """Cell nominal voltage (end of the nominal zone, V_nom), V [src: same]."""
    cell_q_nom: float = 2.07
    """Charge removed at the end of the nominal zone (Q_nom), Ah [src: same]."""
    cell_q: float = 2.3
    """Cell capacity (Q), Ah [src: same]."""
    cell_r: float = 0.010
    """Cell internal resistance, ohm [src: same]."""
    cell_i_fit: float = 2.3
    """Nominal discharge current of the fitted discharge curve (1 C), A [src: same]."""


@dataclass
class PlantParams:
    """All plant parameters."""

    grid: GridParams = field(default_factory=GridParams)
    turbine: TurbineParams = field(default_factory=TurbineParams)
    condenser: CondenserParams = field(default_factory=CondenserParams)
    battery: BatteryParams = field(default_factory=BatteryParams)
    wpp: WppParams = field(default_factory=WppParams)
    n_clusters: int = 5
    """Number of clusters, - [paper]."""
    v_wind: float = 12.0
    """Wind speed at every turbine, m/s [assumed: slightly above rated, pitch-regulated rated output]."""
    sc_connected: bool = True
    """Synchronous condenser in service, - [paper: connected for the SC cases]."""
    topology: str = "farm"
    """"farm" (the 500 MW farm) or "single" (one turbine behind its transformer on an infinite bus)."""
    network_model: str = "quasi_static"
    """"quasi_static" (algebraic Y, the default: phasors at 50 Hz) or "dynamic_phasor" (every line,
    cable, transformer, reactor and capacitor with its own dynamics in the rotating frame, trapezoidal
    at the plant's step: plant/dynamic_network.py) [engineering reason: the cross-check of issue 28
    item 3; run it at a simulator's step, ``dynamic_network.DYNAMIC_STEP_S``]."""
    visc_params: object | None = None
    """sdc_unit.params.ViscParams for ``hd_visc`` turbines (None: ViscParams() when first needed)."""
    onshore_units: int = 0
    """Converter units at the onshore PCC, appended after the farm's turbines (indices n_farm ...), -
    [paper, Section IV-A: "an SDViSC with the same capacity by aggregating four wind turbines [is]
    connected to the onshore point of coupling"; 0 = none, 1 = the paper's comparison arrangement]."""
    onshore_unit_mva: float = 40.0
    """Rating of each onshore unit: four 10 MW turbine converters aggregated as one equivalent, MVA
    [paper: "the same capacity" as the 40 MVAr SC]. Its per-unit parameters are the turbine's (n
    identical units in parallel are one unit of n times the rating with the same per-unit values)."""
    x_onshore_step_up: float = 0.12
    """Onshore unit's 66/400 kV step-up transformer reactance on its rating, p.u. [assumed: the SC's
    ``x_tr`` (IEC 60076-5, 0.12 typical at 40 MVA), so the SDViSC and the SC reach the PCC through the
    same step-up]; in series with its
    aggregated 0.69/66 kV turbine transformers (``GridParams.x_ttr`` on n x ``s_ttr_mva``)."""
