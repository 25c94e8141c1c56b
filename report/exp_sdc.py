"""F1 and F2: the discretised SDC against the HD reference on the full farm, offline (plant/cosim.py:
the SDC's DiscreteVisc stepped every sample on the plant's measurements, its converter-voltage
reference applied through the plant's remote mode; plant/hd_reference.py: the continuous law with the
SDC's own parameters at 50 µs, compared at the SDC's sample instants). F1's SDC drives a plant at
a simulator's step (Ts / 13), as the paper's drove RTDS; F2's a plant at its Ts (0.25 ms)."""

from __future__ import annotations

import numpy as np

from plant import hd_reference
from plant.cosim import QUANTITIES, FaultCase, compare, run_hd, run_sdc
from report import figures
from report.registry import Context, Experiment, Finding, PaperClaim
from report.verdicts import holds

F1_CLAIMS = (
    PaperClaim("F1.a", "The Tustin SDViSC at Ts = 0.67 ms performs as well as the hardware-dependent ViSC "
               "(SLG fault 1.0–1.3 s): almost no deterioration", "no obvious deterioration"),
    PaperClaim("F1.b", "At the fault the ViSCs inject reactive power and bring the system back to normal after "
               "clearance", "Q injected; normal operation after clearing"),
)
F2_CLAIMS = (
    PaperClaim("F2.a", "The trapezoidal-rule (cumulative) SDC at Ts = 0.25 ms collapses, from accumulated "
               "historical error", "collapse at ≈ 2.2 s"),
)
RMS_YES, RMS_PARTLY = 1.0, 5.0  # % of the HD trace's range: the 1 % criterion; 5 % = same in kind
COLLAPSE_DV = 0.05  # p.u.: V_pcc this far from the HD reference = collapsed
LABELS = {"v_pcc": "|V_pcc| [p.u.]", "q": "Q of ViSC wt1_1 [p.u.]", "delta": "δ of wt1_1 [rad]",
          "e_mag": "E of wt1_1 [p.u.]"}


def error_shares(sdc: dict, ref: dict, name: str, windows) -> dict[str, float]:
    """Where in time ``name``'s squared deviation (worst turbine, traces on the same instants) lies: per
    window (lo, hi] [s] its share of the sum [%]."""
    err = np.nan_to_num(sdc[name] - ref[name])
    col = int(np.argmax((err ** 2).sum(axis=0)))
    sq, t = err[:, col] ** 2, ref["t"]
    total = float(sq.sum()) or 1.0
    return {f"{lo:g}–{hi:g} s": 100.0 * float(sq[(t > lo) & (t <= hi)].sum()) / total for lo, hi in windows}


def _windows(case: FaultCase) -> tuple[tuple[float, float], ...]:
    f, c, e = case.t_fault_s, case.t_clear_s, case.t_end_s
    return ((0.0, f), (f, f + 0.01), (f + 0.01, c), (c, c + 0.01), (c + 0.01, c + 0.2), (c + 0.2, e))


def _pct(c: dict) -> dict[str, float]:
    return {q: v["rms_over_range_pct"] for q, v in c.items()}


def _f1(ctx: Context) -> dict[str, Finding]:
    # the paper's set-up: the SDC sampled every 0.67 ms, the plant at a simulator's step (0.67 ms / 13)
    case = FaultCase(plant_steps_per_sample=hd_reference.simulator_steps_per_sample(FaultCase().step_s))
    ref = hd_reference.reference_on_samples(case)
    runs = {k: hd_reference.on_samples(run_sdc(case, method="tustin", delay_samples=k), case) for k in (0, 1)}
    cmp = {k: compare(r, ref) for k, r in runs.items()}
    worst = {k: max(_pct(c).values()) for k, c in cmp.items()}
    # F1net's set-up: the plant steps once per sample (0.67 ms), against the same reference
    coarse_case = FaultCase()
    coarse = run_sdc(coarse_case, method="tustin")
    coarse_pct = _pct(compare(hd_reference.on_samples(coarse, coarse_case),
                              hd_reference.reference_on_samples(coarse_case)))
    same_law = run_hd(coarse_case)  # the SDC's own law and gains inside the plant at 0.67 ms: consistency only
    consistency = _pct(compare(coarse, same_law))
    # the reference is the SDC's own law at 50 µs (issue 39 item 8): the whole gap is the sampling's; beside
    # it, how far the pre-issue-39 reference (the converter's own loop k_pc 1.27) lies from it
    conv_loop = hd_reference.on_samples(run_hd(hd_reference.reference_case(case),
                                               hd_reference.converter_loop_visc_params()), case)
    loop_part, sampling_part = _pct(compare(conv_loop, ref)), _pct(compare(runs[0], ref))
    worst_q = max(cmp[0], key=lambda q: cmp[0][q]["rms_over_range_pct"])
    shares = {q: error_shares(runs[0], ref, q, _windows(case)) for q in QUANTITIES}
    ctx.numbers["rms_over_range_pct"] = cmp
    ctx.numbers["plant_at_ts_pct"] = coarse_pct
    ctx.numbers["consistency_same_law_067ms_pct"] = consistency
    ctx.numbers["hd_with_converter_current_loop_vs_reference_pct"] = loop_part
    ctx.numbers["sdc_vs_reference_pct"] = sampling_part
    ctx.numbers["error_share_by_window_pct"] = shares
    ctx.notes.append(f"The HD reference: {hd_reference.LABEL}, plant/hd_reference.py. The SDC at Ts = "
                     f"{case.step_s * 1e3:.2f} ms drives a plant at Ts / {case.plant_steps_per_sample} = "
                     f"{case.plant_step_s * 1e6:.1f} µs (a simulator's step); both compared at the SDC's sample "
                     "instants (the reference interpolated between its 50 µs rows). With the plant at Ts (F1net's set-up): "
                     + ", ".join(f"{q} {v:.2f} %" for q, v in coarse_pct.items()) + ". Consistency, not the paper's "
                     "reference: that run against the same law with the SDC's own gains (k_pc 0.13) inside the plant "
                     "at 0.67 ms: " + ", ".join(f"{q} {v:.2f} %" for q, v in consistency.items()) + ".")
    _f1_figure(ctx, case, runs, same_law)

    w = worst[0]
    verdict_a = "yes" if w <= RMS_YES else "partly" if w <= RMS_PARTLY else "no"
    per_q = ", ".join(f"{q} {v:.2f} %" for q, v in _pct(cmp[0]).items())
    where = ", ".join(f"{k} {v:.0f} %" for k, v in shares[worst_q].items() if v >= 5)
    reason = (f"criterion ≤ {RMS_YES} % reproduced, ≤ {RMS_PARTLY} % partly, no added delay, against the HD reference "
              f"({hd_reference.LABEL}) at the SDC's sample instants; per quantity: {per_q}. Worst {worst_q}: its squared "
              f"deviation lies {where}. The reference is the SDC's own law (current loop k_pc 0.13) at 50 µs, so "
              f"the {sampling_part[worst_q]:.2f} % is the sampling's; the pre-issue-39 reference with the "
              f"converter's own loop (k_pc 1.27) lies {loop_part[worst_q]:.2f} % from it. With 1 sample of delay "
              f"{worst[1]:.2f} %. With the plant at Ts (0.67 ms, F1net's set-up) {max(coarse_pct.values()):.2f} %. "
              f"Consistency with the same law at 0.67 ms (not the paper's reference) {max(consistency.values()):.2f} %")
    a = Finding(f"worst RMS deviation / HD range {w:.2f} % ({worst_q}, no delay), {worst[1]:.2f} % (1 sample delay)",
                verdict_a, reason, {"worst_pct_delay0": w, "worst_pct_delay1": worst[1],
                                    "worst_quantity": worst_q, "plant_at_ts_worst_pct": max(coarse_pct.values()),
                                    "consistency_worst_pct": max(consistency.values())})
    t = ref["t"]
    during = (t > case.t_fault_s + 0.02) & (t < case.t_clear_s)
    q_fault = float(ref["q"][during].mean())
    v_pre, v_end = float(ref["v_pcc"][t < case.t_fault_s][-1, 0]), float(ref["v_pcc"][-1, 0])
    q_sdc = float(runs[0]["q"][during].mean())
    b = Finding(f"Q during the fault {q_fault:.2f} p.u. (HD), {q_sdc:.2f} (SDC); V_pcc {v_pre:.3f} before, "
                f"{v_end:.3f} at {t[-1]:.1f} s", holds(q_fault > 0.1 and q_sdc > 0.1 and abs(v_end - v_pre) < 0.02),
                "criterion: mean Q > 0.1 p.u. during the fault and V_pcc back within 0.02 p.u. (HD reference; SDC "
                "without added delay)", {"q_fault_hd": q_fault, "q_fault_sdc": q_sdc, "v_pre": v_pre, "v_end": v_end})
    return {"F1.a": a, "F1.b": b}


def _f1_figure(ctx: Context, case: FaultCase, runs: dict, same_law: dict) -> None:
    ref_fine = hd_reference.run_reference(case)
    fig, axes = figures.new(4)
    for ax, name in zip(axes[:, 0], LABELS):
        ax.axvspan(case.t_fault_s, case.t_clear_s, **figures.FAULT_SHADE)
        ax.plot(ref_fine["t"], ref_fine[name][:, 0], "k", lw=1.6, label=hd_reference.LABEL)
        ax.plot(same_law["t"], same_law[name][:, 0], color="0.6", lw=0.8,
                label="same law, SDC's gains, in the plant at 0.67 ms (consistency, not the paper's HD)")
        ax.plot(runs[0]["t"], runs[0][name][:, 0], "C0--", lw=1.0, label="SDViSC Tustin 0.67 ms, no delay (plant 51.5 µs)")
        ax.plot(runs[1]["t"], runs[1][name][:, 0], "C1:", lw=1.2, label="SDViSC Tustin 0.67 ms, 1 sample delay")
        ax.set_ylabel(LABELS[name])
    axes[0, 0].legend(fontsize=7)
    axes[-1, 0].set_xlabel("t [s] (SLG fault at the PCC 1.0–1.3 s; four ViSCs, one per cluster; offline)")
    figures.save(ctx, fig, "f1_tustin_vs_hd", F1_CLAIMS[0].paper + ": " + F1_CLAIMS[0].text)


def _collapse_time(r: dict, ref: dict, t_after: float) -> float | None:
    dv = np.abs(r["v_pcc"][:, 0] - ref["v_pcc"][:, 0])
    bad = (~np.isfinite(dv) | (dv > COLLAPSE_DV)) & (r["t"] > t_after)
    return float(r["t"][np.argmax(bad)]) if bad.any() else None


def _collapse_text(t: float | None) -> str:
    return "no collapse" if t is None else f"collapse at {t:.2f} s"


def _f2(ctx: Context) -> dict[str, Finding]:
    case = FaultCase(step_s=0.25e-3, t_end_s=2.6 if ctx.quick else 3.5)
    ref = hd_reference.reference_on_samples(case)
    tustin = hd_reference.on_samples(run_sdc(case, method="tustin", dtype=np.float64, delay_samples=1), case)
    trap = {d: hd_reference.on_samples(run_sdc(case, method="trapezoid_cumulative", dtype=np.dtype(d),
                                               delay_samples=1), case) for d in ("float32", "float64")}
    collapse = {d: _collapse_time(r, ref, case.t_fault_s) for d, r in trap.items()}
    dev = {d: float(np.nanmax(np.abs(r["v_pcc"] - tustin["v_pcc"]))) for d, r in trap.items()}
    vs_hd = {name: max(_pct(compare(r, ref)).values()) for name, r in (("Tustin", tustin), *trap.items())}
    ctx.numbers["worst_rms_vs_hd_reference_pct"] = vs_hd
    fig, axes = figures.new(2)
    for ax, name in zip(axes[:, 0], ("v_pcc", "delta")):
        ax.axvspan(case.t_fault_s, case.t_clear_s, **figures.FAULT_SHADE)
        ax.plot(ref["t"], ref[name][:, 0], color="0.55", lw=2.4, label=hd_reference.LABEL)
        ax.plot(tustin["t"], tustin[name][:, 0], "k", lw=1.2, label="Tustin, Ts 0.25 ms")
        for d, style in (("float64", "C3--"), ("float32", "C0:")):
            ax.plot(trap[d]["t"], trap[d][name][:, 0], style, lw=1.1, label=f"trapezoid-cumulative {d}")
        ax.set_ylabel(LABELS[name])
    ax = axes[1, 0]
    ax.axvline(2.2, color="C3", lw=0.8, ls="-.", label="paper: collapse at ≈ 2.2 s")
    axes[0, 0].legend(fontsize=7)
    axes[-1, 0].set_xlabel("t [s] (SLG fault 1.0–1.3 s, Ts = 0.25 ms, one sample of delay; offline)")
    figures.save(ctx, fig, "f2_trapezoid_025ms", F2_CLAIMS[0].paper + ": " + F2_CLAIMS[0].text)
    times = [t for t in collapse.values() if t is not None]
    verdict = "no" if not times else "yes" if any(abs(t - 2.2) <= 0.3 for t in times) else "partly"
    shown = ", ".join(f"{d}: {_collapse_text(t)} (max |ΔV_pcc| vs Tustin {dev[d]:.1e} p.u.)"
                      for d, t in collapse.items())
    reason = (f"collapse = V_pcc more than {COLLAPSE_DV} p.u. from the HD reference ({hd_reference.LABEL}) at the "
              f"SDC's samples, over {case.t_end_s} s; worst RMS deviation / HD range: "
              + ", ".join(f"{k} {v:.2f} %" for k, v in vs_hd.items())
              + (". ERRATA 5: the cumulative and recursive forms are the same linear map; only rounding separates "
                 "them, which stays tiny in float64 and in float32 here" if verdict != "yes" else ""))
    return {"F2.a": Finding(shown, verdict, reason, {"collapse_s": collapse, "max_dv_pcc_vs_tustin": dev,
                                                     "worst_pct_vs_hd": vs_hd})}


F1 = Experiment("F1", "Tustin SDC vs hardware-dependent ViSC, SLG fault", "Fig. study1_voltage", "offline", F1_CLAIMS,
                _f1, "", "Offline co-simulation (plant/cosim.py) on the full farm against the HD reference "
                "(plant/hd_reference.py); the same case runs through the network as experiment F1net (scenarios/paper/f1_tustin_vs_hd.yaml).")
F2 = Experiment("F2", "Trapezoidal-cumulative SDC at 0.25 ms", "Fig. study1_VSC_4000", "offline", F2_CLAIMS, _f2,
                "", "Offline co-simulation at Ts = 0.25 ms, float32 (as on a DSP or in GTNET words) and float64.")
