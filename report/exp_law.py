"""LAW1 (beyond the paper, issue 41): the SDC's second law, droop-based grid forming
(sdc_unit/laws/droop.py), in F1's comparison -- offline.

F1's case (SLG fault at the PCC 1.0–1.3 s, four turbines one per cluster, the full farm) with the SDC
running the droop law sampled every Ts = 0.67 ms (the generic trapezoid of the law's rhs,
sdc_unit/law_trapezoid.py) on a plant at a simulator's step (Ts / 13), as F1's SDViSC, against the
droop law's own HD reference (plant.hd_reference.run_law_reference: the law sampled every 50 µs
through the same remote mode, no delay), compared at the SDC's sample instants with F1's measure
(RMS deviation over the reference trace's range). Beside it, the ViSC's reference made the same way
against the plant-integrated HD ViSC: how far the any-law reference is from a law integrated in
the plant."""

from __future__ import annotations

from plant import hd_reference
from plant.cosim import FaultCase, compare, run_law
from report import figures
from report.exp_sdc import LABELS, RMS_PARTLY, RMS_YES
from report.registry import MEASURED, Context, Experiment, Finding, PaperClaim

LAW = "droop"
CLAIMS = (
    PaperClaim("LAW1.a", "A second grid-forming law (droop, Rocabert 2012 / D'Arco & Suul 2014) run by the SDC at "
               "Ts = 0.67 ms: worst RMS deviation from its own HD reference (F1's case and measure)", "not stated",
               beyond=True),
)


def _pct(c: dict) -> dict[str, float]:
    return {q: v["rms_over_range_pct"] for q, v in c.items()}


def _law1(ctx: Context) -> dict[str, Finding]:
    case = FaultCase(plant_steps_per_sample=hd_reference.simulator_steps_per_sample(FaultCase().step_s),
                     t_end_s=1.6 if ctx.quick else 2.0)
    ref_fine = hd_reference.run_law_reference(case, LAW)
    ref = hd_reference.on_samples(ref_fine, case)
    runs = {k: run_law(case, LAW, delay_samples=k) for k in (0, 1)}
    pct = {k: _pct(compare(hd_reference.on_samples(r, case), ref)) for k, r in runs.items()}
    worst = {k: max(p.values()) for k, p in pct.items()}
    worst_q = max(pct[0], key=pct[0].get)
    visc_ref = hd_reference.on_samples(hd_reference.run_law_reference(case, "visc"), case)
    visc_hd = hd_reference.reference_on_samples(case)
    ref_vs_hd = max(_pct(compare(visc_ref, visc_hd)).values())
    trips = {k: int(r["trips"].sum()) for k, r in runs.items()}
    ctx.numbers["rms_over_range_pct"] = pct
    ctx.numbers["visc_any_law_reference_vs_hd_visc_worst_pct"] = ref_vs_hd
    ctx.notes.append(f"LAW1: the droop law's HD reference is {hd_reference.LAW_LABEL}; made the same way for the "
                     f"ViSC it lies {ref_vs_hd:.3f} % (worst quantity) from the plant-integrated HD ViSC.")
    fig, axes = figures.new(4)
    for ax, name in zip(axes[:, 0], LABELS):
        ax.axvspan(case.t_fault_s, case.t_clear_s, **figures.FAULT_SHADE)
        ax.plot(ref_fine["t"], ref_fine[name][:, 0], "k", lw=1.6, label=f"droop law: {hd_reference.LAW_LABEL}")
        ax.plot(runs[0]["t"], runs[0][name][:, 0], "C0--", lw=1.0, label="droop law in the SDC, 0.67 ms, no delay")
        ax.plot(runs[1]["t"], runs[1][name][:, 0], "C1:", lw=1.2, label="droop law in the SDC, 1 sample delay")
        ax.set_ylabel(LABELS[name].replace("ViSC ", ""))
    axes[0, 0].legend(fontsize=7)
    axes[-1, 0].set_xlabel("t [s] (SLG fault at the PCC 1.0–1.3 s; four droop-law turbines, one per cluster; offline)")
    figures.save(ctx, fig, "law1_droop_vs_its_hd", CLAIMS[0].text)
    per_q = ", ".join(f"{q} {v:.2f} %" for q, v in pct[0].items())
    reason = (f"F1's measure against the droop law's own HD reference, per quantity (no delay): {per_q}; with one "
              f"sample of delay {worst[1]:.2f} %; converter trips {trips[0]} (no delay), {trips[1]} (1 sample). "
              f"For scale: F1's criterion is ≤ {RMS_YES} % (≤ {RMS_PARTLY} % same in kind)")
    return {"LAW1.a": Finding(f"worst RMS deviation / reference range {worst[0]:.2f} % ({worst_q}, no delay), "
                              f"{worst[1]:.2f} % (1 sample delay)", MEASURED, reason,
                              {"worst_pct_delay0": worst[0], "worst_pct_delay1": worst[1], "worst_quantity": worst_q,
                               "trips": trips, "visc_reference_vs_hd_visc_pct": ref_vs_hd})}


LAW1 = Experiment("LAW1", "A second SDC law (droop) against its own HD reference", "— (beyond the paper)", "offline",
                  CLAIMS, _law1, "", "Beyond the paper (issue 41), offline: F1's case in plant/cosim.py (run_law) with "
                  "the droop law of sdc_unit/laws/droop.py against its HD reference (plant/hd_reference.py "
                  "run_law_reference); through the network: scenarios/droop_law.yaml.")
