"""F3–F6: the SDViSC against the synchronous condenser on the offline farm (voltage regulation and
stiffness, inertia support with 50 and 100 MW load steps, short-circuit contribution), in the
paper's comparison arrangement (Section IV-A): the 40 MVAr SC, or one 40 MVA SDViSC (four turbine
converters aggregated, the continuous law inside the plant: hd_visc), at the onshore PCC beside the
producing farm (plant.cases.comparison_visc_plant). Which bus each figure most plausibly shows is
said in docs/report.md ("Which voltage"): the devices' own terminals for F3 (a) and F6, the PCC for
F3 (b); the PCC trace is plotted beside the terminal one."""

from __future__ import annotations

import numpy as np
from scipy.signal import detrend, periodogram

from plant.battery import BatteryBank
from plant.cases import COMPARISON_UNIT, comparison_visc_plant
from plant.params import BatteryParams, TurbineParams
from report import figures
from report.dynamic_cases import DYN_T0, _every, dynamic
from report.plantcases import FAULT_SLG, bare_plant, sc_plant, t90, visc_indices, window
from report.registry import INPUT, Context, Experiment, Finding, PaperClaim
from report.verdicts import change_close_to, close_to, holds
from sdc_unit.params import ViscParams

VISC = [COMPARISON_UNIT]  # the aggregated 40 MVA SDViSC at the PCC (quantities on its own 40 MVA base)
CLUSTER_VISC = visc_indices(4)  # the cluster-3 variant (four 10 MW SDViSCs in the farm)
GRID_INERTIA = {"h_grid": 5.0, "s_grid_mva": 1000.0}  # assumed (docs/plant.md): a finite-inertia grid source


def _worst(*verdicts: str) -> str:
    return "no" if "no" in verdicts else "partly" if "partly" in verdicts else "yes"


# ------------------------------------------------------------------------------------------------ F3
F3_CLAIMS = (
    PaperClaim("F3.a", "AVR reference 1.00 → 1.04 at 1 s: both the SC and the SDViSC boost the voltage to "
               "about 1.035 p.u. finally", "≈ 1.035 p.u. (both)"),
    PaperClaim("F3.b", "The SDViSC regulates faster than the SC", "faster"),
    PaperClaim("F3.c", "Voltage stiffness: with a larger T_v = 1/K_iv the rate of change of the PCC voltage after a "
               "0.08 p.u. grid voltage drop is reduced", "lower dV/dt with larger T_v"),
    PaperClaim("F3.d", "… the static deviation of the voltage is not improved", "same final deviation"),
    PaperClaim("F3.e", "… and the voltage nadir is pulled up", "higher nadir with larger T_v"),
)
K_IV = (20.0, 10.0, 5.0)  # T_v = 0.05, 0.1, 0.2 s (the paper does not print its values)


def _f3(ctx: Context) -> dict[str, Finding]:
    t_sc = 4.0 if ctx.quick else 6.0
    p = sc_plant()
    ref0 = p.sc.v_ref
    r_sc = p.run_offline(t_sc, events=[(1.0, lambda q: q.set_avr_ref(ref0 + 0.04))], record_every=10)
    p = comparison_visc_plant()
    vp = p.visc_params
    r_v = p.run_offline(3.0, events=[(1.0, lambda q: q.set_visc_params(vp.with_changes(v_ref=vp.v_ref + 0.04)))],
                        record_every=10)
    terminal = {"SC": r_sc["v_sc"], "SDViSC": r_v["v_wt"][:, COMPARISON_UNIT]}
    step = {}
    for name, r in (("SC", r_sc), ("SDViSC", r_v)):
        v_t, before = terminal[name], r["t"] < 1.0
        step[name] = {"v_before": float(v_t[before][-1]), "v_after": float(v_t[-1]),
                      "t90_s": t90(r["t"], v_t, 1.0),
                      "v_pcc_before": float(r["v_pcc"][before][-1]), "v_pcc_after": float(r["v_pcc"][-1])}
    verdicts = [change_close_to(s["v_before"], s["v_after"], 1.0, 1.035) for s in step.values()]
    a = Finding(", ".join(f"{n}: terminal {s['v_before']:.3f} → {s['v_after']:.3f} (PCC {s['v_pcc_before']:.3f} → "
                          f"{s['v_pcc_after']:.3f})" for n, s in step.items()), _worst(*verdicts),
                "rise of each device's own terminal voltage (the bus its AVR regulates) compared with the paper's "
                "1.00 → 1.035: with droop m_q = 0.02 the AVR holds V_t = V* − m_q Q, and Q = (V_t − V_pcc)/x of the "
                "step-up, so V_t ≈ 1.035 at V* = 1.04 — the paper's value is what a terminal shows. The PCC itself "
                "moves ≈ ΔQ/S_k (S_k = 3570 MVA at SCR 7.14): +3.5 % there would need ≈ 125 Mvar, 40 MVA give "
                "≈ 0.1–0.3 % (the PCC values beside)",
                {**step, "printed": {"reading": "each device's own terminal, positive-sequence RMS, final value after "
                                                "V* 1.00 → 1.04 (SC and SDViSC)",
                                     "value": " / ".join(f"{n} {s['v_after']:.3f}" for n, s in step.items()),
                                     "alternatives": {f"PCC, {n} case": round(s["v_pcc_after"], 4)
                                                      for n, s in step.items()}}})
    b = Finding(f"t90 SC {step['SC']['t90_s']:.2f} s, SDViSC {step['SDViSC']['t90_s']:.2f} s",
                holds(step["SDViSC"]["t90_s"] < step["SC"]["t90_s"]),
                "t90 = time after 1 s until the terminal voltage covers 90 % of its final change",
                {k: s["t90_s"] for k, s in step.items()})

    stiff = {}
    for k_iv in K_IV:
        p = comparison_visc_plant(visc_params=vp.with_changes(k_iv=k_iv))
        e0 = p.params.grid.e_grid
        r = p.run_offline(3.0, events=[(1.0, lambda q, e0=e0: q.set_grid_emf(e0 - 0.08))], record_every=1)
        t, v = r["t"], r["v_pcc"]
        after = window(r, 1.005, 1.5)  # after the instantaneous (network) part of the drop
        stiff[k_iv] = {"t": t, "v": v, "max_rate": float(np.max(np.abs(np.gradient(v, t)[after]))),
                       "nadir": float(v[t > 1.0].min()), "deviation": float(v[-1] - v[t < 1.0][-1])}
    rates = [stiff[k]["max_rate"] for k in K_IV]
    nadirs = [stiff[k]["nadir"] for k in K_IV]
    devs = [stiff[k]["deviation"] for k in K_IV]
    tv = ", ".join(f"T_v {1 / k:.2f} s" for k in K_IV)
    why = (f"the T_v cases differ by {np.ptp(rates):.3f} p.u./s in rate and {np.ptp(nadirs):.4f} p.u. in nadir: 40 MVA "
           "hardly move a 3570 MVA PCC, and in this law a smaller K_iv (larger T_v) makes E follow the voltage error "
           "more slowly, i.e. less support in the first instants (rate = max |dV/dt| over 1.005–1.5 s)")
    c = Finding(f"max |dV_pcc/dt| after the drop {', '.join(f'{x:.3f}' for x in rates)} p.u./s ({tv})",
                holds(rates[0] > rates[1] > rates[2]), why, {"max_rate_pu_per_s": rates, "t_v_s": [1 / k for k in K_IV]})
    d = Finding(f"final deviation {', '.join(f'{x:+.4f}' for x in devs)} p.u.", holds(np.ptp(devs) < 0.002),
                "criterion: the final deviations differ by < 0.002 p.u.", {"deviation_pu": devs})
    e = Finding(f"nadir {', '.join(f'{x:.4f}' for x in nadirs)} p.u.", holds(nadirs[0] < nadirs[1] < nadirs[2]),
                why, {"nadir_pu": nadirs})

    fig, axes = figures.new(2, 1, sharex=False)
    ax = axes[0, 0]
    ax.plot(r_sc["t"], terminal["SC"], "C0", label="SC terminal, AVR ref +0.04 at 1 s")
    ax.plot(r_v["t"], terminal["SDViSC"], "C1", label="40 MVA SDViSC terminal, V* +0.04 at 1 s")
    ax.plot(r_sc["t"], r_sc["v_pcc"], "C0", ls="--", lw=0.8, label="PCC, SC case")
    ax.plot(r_v["t"], r_v["v_pcc"], "C1", ls="--", lw=0.8, label="PCC, SDViSC case")
    ax.axhline(1.035, color="0.5", ls=":", lw=0.8, label="paper: ≈ 1.035")
    ax.set_ylabel("|V| [p.u.]")
    ax.set_xlabel("t [s]")
    ax.legend(fontsize=7)
    ax = axes[1, 0]
    for k_iv in K_IV:
        ax.plot(stiff[k_iv]["t"], stiff[k_iv]["v"], lw=1.0, label=f"T_v = 1/K_iv = {1 / k_iv:.2f} s")
    ax.set_ylabel("|V_pcc| [p.u.]")
    ax.set_xlabel("t [s] (grid EMF −0.08 p.u. at 1 s, 40 MVA SDViSC at the PCC)")
    ax.legend(fontsize=7)
    figures.save(ctx, fig, "f3_voltage_regulation", "both the SC and the SDViSC boost the voltage to around 1.035 p.u.; "
                 "the SDViSC is faster; a larger T_v slows the voltage change and pulls the nadir up.")
    return {"F3.a": a, "F3.b": b, "F3.c": c, "F3.d": d, "F3.e": e}


# ------------------------------------------------------------------------------------------- F4, F5
F4_CLAIMS = (
    PaperClaim("F4.a", "+50 MW load: with the same H = 3 s the frequency nadir is almost the same for the SDViSC "
               "and the SC", "nadir SDViSC ≈ SC"),
    PaperClaim("F4.b", "A larger SDViSC inertia (H 5 s vs 3 s) clearly reduces the frequency dip", "smaller nadir"),
    PaperClaim("F4.c", "… and lowers the oscillation frequency", "lower oscillation frequency"),
)
F5_CLAIMS = (
    PaperClaim("F5.a", "+100 MW load, same H = 4 s: the dip is larger with the SDViSC than with the SC (limited "
               "stored energy)", "SDViSC dip > SC dip"),
    PaperClaim("F5.b", "A 2000 Ah Li-ion battery on the DC link clearly reduces the SDViSC's frequency dip",
               "obviously smaller nadir"),
)


def _load_step(plant, mw: float, t_end: float, visc=None) -> dict:
    """Frequency nadir, dominant oscillation and the SDViSCs' DC link and batteries after +``mw`` at
    1 s; ``visc``: the SDViSC converters' indices (default: the comparison unit if the plant has one,
    else the cluster-3 four)."""
    if visc is None:
        visc = VISC if plant.n > COMPARISON_UNIT else CLUSTER_VISC
    r = plant.run_offline(t_end, events=[(1.0, lambda q: q.load_step(mw))], record_every=5)
    t, f = r["t"], r["f_pcc_hz"]
    after = t > 1.0
    osc = detrend(f[after])
    freqs, power = periodogram(osc, fs=1.0 / (t[1] - t[0]), nfft=16 * len(osc))  # zero-padded: finer peak
    return {"t": t, "f": f, "nadir_hz": float(f.min() - 50.0), "osc_hz": float(freqs[1:][np.argmax(power[1:])]),
            "v_dc_min": float(r["v_dc"][:, visc].min()),
            # the SDViSCs' batteries (zero without): SOC change over the run, peak power, energy delivered
            "d_soc": float(np.max(np.abs(r["soc"][-1, visc] - r["soc"][0, visc]))),
            "p_batt_max": float(r["p_batt"][:, visc].max()),
            "i_batt_max": float((r["p_batt"][:, visc] / r["v_dc"][:, visc]).max()),
            "e_batt_mwh": float(r["e_batt_mwh"][-1, visc].max())}


def _f4(ctx: Context) -> dict[str, Finding]:
    t_end = 3.0 if ctx.quick else 4.0
    runs = {"SC H 3 s": _load_step(sc_plant(h_sc=3.0, **GRID_INERTIA), 50.0, t_end)}
    for h in (3.0, 5.0):
        runs[f"SDViSC H {h:g} s"] = _load_step(comparison_visc_plant(visc_params=ViscParams(h=h), **GRID_INERTIA), 50.0,
                                               t_end)
    sc, v3, v5 = (runs[k] for k in ("SC H 3 s", "SDViSC H 3 s", "SDViSC H 5 s"))
    a = Finding(f"nadir SC {sc['nadir_hz']:.3f} Hz, SDViSC {v3['nadir_hz']:.3f} Hz",
                close_to(v3["nadir_hz"], sc["nadir_hz"]), "relative to the SC's nadir (10 % yes, 35 % partly)",
                {"sc": sc["nadir_hz"], "visc_h3": v3["nadir_hz"]})
    gain = v5["nadir_hz"] - v3["nadir_hz"]
    sensitivity = {} if ctx.quick else _f4_sensitivity(t_end)
    ctx.numbers["sensitivity_nadir_hz"] = sensitivity
    b = Finding(f"nadir H 3 s {v3['nadir_hz']:.4f} Hz, H 5 s {v5['nadir_hz']:.4f} Hz (Δ {gain:+.4f} Hz)",
                holds(gain >= 0.05 * abs(v3["nadir_hz"]), partly=gain > 0),
                "clear = ≥ 5 % of the nadir. 40 MVA × H = 120–200 MWs against a grid source of 5000 MWs "
                "(assumed), and D = 90 makes the law follow the grid within 2H/D ≈ 67 ms"
                + "".join(f"; {case}: H 3 s {n[0]:.4f}, H 5 s {n[1]:.4f} Hz" for case, n in sensitivity.items()),
                {"gain_hz": gain})
    c = Finding(f"dominant oscillation {v3['osc_hz']:.2f} Hz (H 3 s), {v5['osc_hz']:.2f} Hz (H 5 s)",
                holds(v5["osc_hz"] < v3["osc_hz"]),
                f"largest peak of the zero-padded periodogram of the detrended PCC frequency over 1–{t_end:g} s (a "
                f"{t_end - 1:g} s window: peaks closer than ≈ {1 / (t_end - 1):.2f} Hz are not resolved); the grid source's "
                "own swing (H 5 s on 1000 MVA, assumed) dominates what 40 MVA of SDViSC changes",
                {"osc_hz_h3": v3["osc_hz"], "osc_hz_h5": v5["osc_hz"]})
    _figure_freq(ctx, runs, "f4_inertia_50mw", "+50 MW at 1 s", "the frequency nadir is almost the same for the "
                 "SDViSC and the SC with H = 3 s; a larger SDViSC H decreases the nadir and the oscillation frequency.")
    return {"F4.a": a, "F4.b": b, "F4.c": c}


def _f4_sensitivity(t_end: float) -> dict[str, tuple[float, float]]:
    """The F4.b nadirs (H 3 s, H 5 s) with other assumptions: the law's D, the grid's inertia, ω_s."""
    cases = {"D = 20": ({"d": 20.0}, GRID_INERTIA),
             "grid source H 2 s on 500 MVA": ({}, {"h_grid": 2.0, "s_grid_mva": 500.0}),
             "ω_s measured": ({"omega_s_measured": True}, GRID_INERTIA)}
    return {case: tuple(_load_step(comparison_visc_plant(visc_params=ViscParams(h=h, **law), **grid), 50.0,
                                   t_end)["nadir_hz"]
                        for h in (3.0, 5.0)) for case, (law, grid) in cases.items()}


def _f5(ctx: Context) -> dict[str, Finding]:
    t_end = 3.0 if ctx.quick else 4.0
    vp = ViscParams(h=4.0)
    runs = {"SC H 4 s": _load_step(sc_plant(h_sc=4.0, **GRID_INERTIA), 100.0, t_end),
            "SDViSC H 4 s": _load_step(comparison_visc_plant(visc_params=vp, **GRID_INERTIA), 100.0, t_end),
            "SDViSC H 4 s + battery": _load_step(comparison_visc_plant(visc_params=vp, battery=True, **GRID_INERTIA),
                                                 100.0, t_end),
            "SDViSC H 4 s, ω_s measured": _load_step(
                comparison_visc_plant(visc_params=vp.with_changes(omega_s_measured=True), **GRID_INERTIA), 100.0, t_end)}
    sc, v, vb, vm = runs.values()
    a = Finding(f"nadir SC {sc['nadir_hz']:.3f} Hz, SDViSC {v['nadir_hz']:.3f} Hz (v_dc min {v['v_dc_min']:.2f})",
                holds(v["nadir_hz"] < sc["nadir_hz"], partly=vm["nadir_hz"] < sc["nadir_hz"]),
                f"the law's default ω_s = 1 p.u. (nominal) makes D = 90 a 1.1 % frequency droop; with ω_s = the "
                f"measured frequency (pure inertia) the SDViSC's nadir is {vm['nadir_hz']:.3f} Hz (v_dc min "
                f"{vm['v_dc_min']:.2f}); yes = worse than the SC with the default law, partly = only with ω_s measured",
                {"sc": sc["nadir_hz"], "visc": v["nadir_hz"], "v_dc_min": v["v_dc_min"],
                 "visc_omega_s_measured": vm["nadir_hz"]})
    gain = vb["nadir_hz"] - v["nadir_hz"]
    bp, tp = BatteryParams(), TurbineParams()
    batt = BatteryBank(bp, tp, 1)
    at_limit = vb["i_batt_max"] >= 0.99 * batt.i_dis_max
    b = Finding(f"nadir {v['nadir_hz']:.3f} → {vb['nadir_hz']:.3f} Hz with the battery (v_dc min "
                f"{v['v_dc_min']:.2f} → {vb['v_dc_min']:.2f}); each battery: peak {vb['p_batt_max']:.2f} p.u. "
                f"({vb['p_batt_max'] * tp.s_rated_mva:.1f} MW), SOC −{vb['d_soc'] * 100:.3f} % "
                f"({vb['e_batt_mwh'] * 1e3:.1f} kWh) from the step at 1 s to {t_end:g} s",
                holds(gain >= 0.05 * abs(v["nadir_hz"]), partly=gain > 0),
                f"clear = ≥ 5 % of the nadir. The battery (plant/battery.py, docs/plant.md): {bp.capacity_ah:g} Ah of "
                f"A123 LiFePO4 cells in parallel with the {tp.v_dc_base_kv:g} kV DC link "
                f"({bp.capacity_ah * tp.v_dc_base_kv / 1e3:.1f} MWh), OCV(SOC) of the Tremblay–Dessaint model, pack "
                f"resistance {batt.r:.3f} p.u., current limit {bp.c_rate_discharge:g} C ({batt.i_dis_max:.2f} p.u.), "
                f"SOC window {bp.soc_min:.0%}–{bp.soc_max:.0%}, from SOC {bp.soc_init:g}. The event uses "
                f"{vb['d_soc'] * 100:.2g} % of the charge and the peak current ({vb['i_batt_max']:.2f} p.u.) is "
                f"{'at' if at_limit else 'below'} the limit: over seconds the capacity does not bind; the battery "
                "holds the DC link up (its resistance sets how far v_dc sags"
                f"{', its current limit how much it can give' if at_limit else ''}), so the SDViSC can deliver "
                "the power its law asks for",
                {"gain_hz": gain, "v_dc_min_battery": vb["v_dc_min"], "soc_change": -vb["d_soc"],
                 "p_batt_max_pu": vb["p_batt_max"], "i_batt_max_pu": vb["i_batt_max"], "e_batt_mwh": vb["e_batt_mwh"]})
    _figure_freq(ctx, runs, "f5_inertia_100mw_battery", "+100 MW at 1 s", "with the same H = 4 s the SDViSC's "
                 "frequency dip is larger than the SC's; a 2000 Ah battery on the DC link obviously reduces it.")
    return {"F5.a": a, "F5.b": b}


def _figure_freq(ctx: Context, runs: dict, name: str, event: str, caption: str) -> None:
    fig, axes = figures.new(1, height_per_row=3.2)
    ax = axes[0, 0]
    for label, r in runs.items():
        ax.plot(r["t"], r["f"], lw=1.0, label=f"{label} (nadir {r['nadir_hz']:+.3f} Hz)")
    ax.set_ylabel("PCC frequency [Hz]")
    ax.set_xlabel(f"t [s] ({event}; grid source H 5 s on 1000 MVA, assumed; SCR 7.14)")
    ax.legend(fontsize=7)
    figures.save(ctx, fig, name, caption)


# ------------------------------------------------------------------------------------------------ F6
F6_CLAIMS = (
    PaperClaim("F6.a", "SLG fault 1.0–1.2 s: the SC's short-circuit current rises to 4 p.u.", "≈ 4 p.u."),
    PaperClaim("F6.b", "… with the SC the residual voltage is above 0.7 p.u.", "> 0.7 p.u."),
    PaperClaim("F6.c", "The SDViSC's contribution is limited by its overcurrent capability", "1.5 p.u.",
               kind=INPUT),  # the SDViSC's 1.5 p.u. limit is the law's i_max (sdc_unit/params.py)
    PaperClaim("F6.d", "… its residual voltage is about 0.6 p.u., lower than the SC's", "≈ 0.6 p.u. (< SC)"),
    PaperClaim("F6.e", "Both inject reactive power during the fault", "Q > 0 (both)"),
)


def iec60909_kappa(r_over_x: float) -> float:
    """Peak factor of a short-circuit current, i_p = kappa sqrt(2) I''_k [src: IEC 60909-0:2016, eq. 55]."""
    return 1.02 + 0.98 * float(np.exp(-3.0 * r_over_x))


F6_FAULT = (1.0, 1.2)  # s: the SLG fault's instant and its clearance (the paper's figure: 1.0–1.2 s)


def f6_events(t_on: float = F6_FAULT[0]) -> list:
    """F6's fault (0.2 s long) from ``t_on``; NM runs the same fault earlier in its dynamic-network runs."""
    return [(t_on, lambda q: q.fault(True)), (t_on + F6_FAULT[1] - F6_FAULT[0], lambda q: q.fault(False))]


def f6_numbers(r_sc: dict, r_v: dict, condenser, t_on: float = F6_FAULT[0]) -> dict[str, float]:
    """F6's numbers from the SC run ``r_sc`` and the SDViSC run ``r_v`` with the fault at ``t_on``:
    the SC's initial symmetrical phase current I'' (largest phase RMS current in the first cycle),
    κ and κ I'', each device's terminal V1 and the PCC's, means over t_on + 0.05 … t_on + 0.19 s."""
    f_sc, f_v = (window(r, t_on + 0.05, t_on + 0.19) for r in (r_sc, r_v))
    first = window(r_sc, t_on, t_on + 0.02)  # the first cycle: the subtransient current I''
    kappa = iec60909_kappa(condenser.ra / (condenser.xd2 + condenser.x_tr))
    i_initial = float(r_sc["i_sc_ph_max"][first].max())
    return {"i_initial": i_initial, "kappa": kappa,
            "i_peak_max": kappa * i_initial,  # p.u. of the rated peak: full DC offset (the worst point on wave)
            "v_t_sc": float(r_sc["v_sc"][f_sc].mean()), "v_pcc_sc": float(r_sc["v_pcc"][f_sc].mean()),
            "v_t_v": float(r_v["v_wt"][f_v, COMPARISON_UNIT].mean()), "v_pcc_v": float(r_v["v_pcc"][f_v].mean())}


def sc_first_peak_dynamic() -> float:
    """The SC's first-cycle maximum phase current on the dynamic-phasor network (its inductances keep
    their current at the fault's instant: the DC offset, which the quasi-static network has not), F6's
    fault from rest at 0.1 s (≈ 2 s of wall time) [report/exp_network_model.py runs the same]."""

    p = dynamic(sc_plant)
    r = p.run_offline(DYN_T0 + 0.03, events=f6_events(DYN_T0), record_every=_every(p.step_s, 2.5e-4))
    return float(r["i_sc_ph_max"][window(r, DYN_T0, DYN_T0 + 0.02)].max())


def _f6(ctx: Context) -> dict[str, Finding]:
    events = f6_events()
    p_sc = sc_plant()
    r_sc = p_sc.run_offline(2.0, events=events, record_every=1)
    r_v = comparison_visc_plant().run_offline(2.0, events=events, record_every=5)
    r_0 = bare_plant().run_offline(1.4, events=events, record_every=5)
    f_sc, f_v, f_0 = (window(r, 1.05, 1.19) for r in (r_sc, r_v, r_0))
    c = p_sc.params.condenser
    nums = f6_numbers(r_sc, r_v, c)
    kappa, i_initial, i_peak_max = nums["kappa"], nums["i_initial"], nums["i_peak_max"]
    peak = sc_first_peak_dynamic()
    u = COMPARISON_UNIT
    v_t_sc, v_t_v, v_sc, v_v = nums["v_t_sc"], nums["v_t_v"], nums["v_pcc_sc"], nums["v_pcc_v"]
    v_0 = float(r_0["v_pcc"][f_0].mean())
    i_v = float(r_v["i_wt"][:, u].max())
    q_sc, q_v = float(r_sc["q_sc"][f_sc].mean()), float(r_v["q_wt"][f_v, u].mean())
    found = {
        "F6.a": Finding(f"SC first peak {peak:.2f} p.u. (dynamic-phasor network); quasi-static I'' {i_initial:.2f}, "
                        f"κ I'' {i_peak_max:.2f} (IEC 60909 κ = {kappa:.3f})", close_to(peak, 4.0),
                        "the paper's curve is an instantaneous current (RTDS, EMT): judged is the simulated first "
                        "peak of the SC's largest phase current, on the dynamic-phasor network (the DC offset "
                        f"included), by the 10 % rule ({(peak - 4.0) / 4.0:+.1%}). Context only, never the verdict: "
                        "the quasi-static model's I'' (no offset) and IEC 60909's κ I'' (full offset; κ from the SC "
                        f"branch's R/X {c.ra / (c.xd2 + c.x_tr):.3f}) bound any first peak; x''_d 0.20 and the step-up "
                        "0.10 are typical values (docs/plant.md)",
                        {"i_sc_first_peak_dynamic": peak, "i_sc_initial_phase": i_initial, "kappa": kappa,
                         "i_sc_peak_full_offset": i_peak_max,
                         "i_sc_phase_window_max": float(r_sc["i_sc_ph_max"][f_sc].max()),
                         "printed": {"reading": "SC, largest phase current, instantaneous first peak (dynamic-phasor "
                                                "network), p.u. of the rated peak", "value": round(peak, 3),
                                     "alternatives": {"quasi-static I''": round(i_initial, 3),
                                                      "κ I'' (full offset)": round(i_peak_max, 3)}}}),
        "F6.b": Finding(f"SC terminal V1 {v_t_sc:.3f} p.u. during the fault (PCC {v_sc:.3f}; no device: {v_0:.3f})",
                        holds(v_t_sc > 0.7),
                        "a bound, judged as one (held or not; not a magnitude within 10 %): the SC's own terminal "
                        "(the bus its AVR regulates, as in F3), positive sequence; the PCC beside. F6.b and F6.d "
                        "cannot both hold at one bus in this model: at the PCC the SC case gives "
                        f"{v_sc:.3f} and the SDViSC case {v_v:.3f} ({abs(v_sc - v_v):.3f} apart; a 40 MVA device "
                        "hardly moves a 3570 MVA PCC), so > 0.7 with the SC and ≈ 0.6 with the SDViSC exclude each "
                        "other at one bus; each holds only at its own device's terminal",
                        {"v1_sc_terminal": v_t_sc, "v1_pcc_sc": v_sc, "v1_pcc_none": v_0,
                         "printed": {"reading": "SC terminal, positive-sequence RMS, mean during the fault (a bound)",
                                     "value": round(v_t_sc, 3), "bound": True,
                                     "alternatives": {"PCC (SC case)": round(v_sc, 3), "PCC, no device": round(v_0, 3)}}}),
        "F6.c": Finding(f"largest SDViSC |i| {i_v:.3f} p.u.", close_to(i_v, 1.5, 0.05, 0.1),
                        "largest |i| of the 40 MVA SDViSC over the run (within 5 % of 1.5 = yes; the limiter acts "
                        "on the law's reference, the converter's current loop overshoots it by a little at the "
                        "fault's instants). An input of the model: the paper sets the limit", {"i_visc_max": i_v}),
        "F6.d": Finding(f"SDViSC terminal V1 {v_t_v:.3f} p.u. (SC terminal {v_t_sc:.3f}); PCC {v_v:.3f} (SC case "
                        f"{v_sc:.3f})", holds(close_to(v_t_v, 0.6) == "yes" and v_t_v < v_t_sc,
                                             partly=close_to(v_v, 0.6) == "yes"),
                        "the converter's own terminal, as the SC's: the SDViSC's 1.5 p.u. of reactive current through "
                        "its transformers (0.17 p.u. on 40 MVA) lift its terminal above the PCC; the SC's "
                        "positive-sequence current during the fault is only ≈ 1.2 p.u. (its phase maximum is "
                        "negative sequence), so at the PCC too the SDViSC case is not lower. Partly = the PCC in the "
                        "SDViSC case is ≈ 0.6 (within 10 %)",
                        {"v1_visc_terminal": v_t_v, "v1_pcc_visc": v_v,
                         "printed": {"reading": "SDViSC terminal, positive-sequence RMS, mean during the fault",
                                     "value": round(v_t_v, 3), "verdict": close_to(v_t_v, 0.6),
                                     "alternatives": {"PCC (SDViSC case)": round(v_v, 3)}}}),
        "F6.e": Finding(f"Q SC {q_sc:.2f} p.u., SDViSC {q_v:.2f} p.u. (both 40 MVA)",
                        holds(q_sc > 0.1 and q_v > 0.1),
                        "mean Q over 1.05–1.19 s above 0.1 p.u. for both", {"q_sc": q_sc, "q_visc": q_v}),
    }
    fig, axes = figures.new(3)
    for ax in axes[:, 0]:
        ax.axvspan(1.0, 1.2, **figures.FAULT_SHADE)
    axes[0, 0].plot(r_sc["t"], r_sc["i_sc_ph_max"], "C0", label="SC, largest phase current (RMS)")
    axes[0, 0].axhline(i_peak_max, color="C0", ls=":", lw=0.8, label=f"κ I'' = {i_peak_max:.2f} (full DC offset)")
    axes[0, 0].plot(r_v["t"], r_v["i_wt"][:, u], "C1", label="SDViSC |i|")
    axes[0, 0].set_ylabel("current [p.u., own base]")
    axes[1, 0].plot(r_sc["t"], r_sc["v_sc"], "C0", label="SC terminal")
    axes[1, 0].plot(r_v["t"], r_v["v_wt"][:, u], "C1", label="SDViSC terminal")
    axes[1, 0].plot(r_sc["t"], r_sc["v_pcc"], "C0", ls="--", lw=0.8, label="PCC, SC case")
    axes[1, 0].plot(r_v["t"], r_v["v_pcc"], "C1", ls="--", lw=0.8, label="PCC, SDViSC case")
    axes[1, 0].set_ylabel("V1 [p.u.]")
    axes[2, 0].plot(r_sc["t"], r_sc["q_sc"], "C0", label="SC")
    axes[2, 0].plot(r_v["t"], r_v["q_wt"][:, u], "C1", label="SDViSC")
    axes[2, 0].set_ylabel("Q [p.u., 40 MVA]")
    axes[2, 0].set_xlabel(f"t [s] ({FAULT_SLG} 1.0–1.2 s, SCR 7.14; positive-sequence RMS model)")
    for ax in axes[:, 0]:
        ax.legend(fontsize=7)
    figures.save(ctx, fig, "f6_short_circuit", "the SC's short-circuit current rises to 4 p.u. with a residual "
                 "voltage above 0.7 p.u.; the SDViSC is limited to 1.5 p.u. with a residual voltage of about 0.6 p.u.")
    return found


F3 = Experiment("F3", "Voltage regulation and stiffness, SDViSC vs SC", "Fig. Compare_Volg", "offline", F3_CLAIMS, _f3,
                "", "Offline, hd_visc SDViSCs (SC out of service) and the SC case; T_v values assumed (0.05/0.1/0.2 s).")
F4 = Experiment("F4", "Inertia support, +50 MW", "Fig. Compare_inertia1", "offline", F4_CLAIMS, _f4, "",
                "Offline; grid source with H 5 s on 1000 MVA (assumed) so that the frequency can move.")
F5 = Experiment("F5", "Inertia support, +100 MW, battery", "Fig. Compare_inertia3", "offline", F5_CLAIMS, _f5, "",
                "Offline; the battery is a 2000 Ah Li-ion model with state of charge (plant/battery.py).")
F6 = Experiment("F6", "Short-circuit contribution, SLG fault", "Fig. Compare_ShortC", "offline", F6_CLAIMS, _f6, "",
                "Offline; single-phase-to-ground fault through the sequence networks (RMS model).")
