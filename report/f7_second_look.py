"""F7's second look (issue 39 item 1), for report/exp_weak.py: per case the step boundary with the
plant controller as before issue 39, the slow-ramp boundary with both controllers, the mechanism of
each loss and the linearised checks at the step and ramp boundaries (report/f7_mechanism.py), and
their figure."""

from __future__ import annotations

import functools
import textwrap

import numpy as np

from report import f7_mechanism as mech
from report import figures
from report.registry import Context
from report.stability import LAST_S, V_NORMAL
from report.weak_cases import CONFIGS, F7_CONFIGS, T_EVENT, WPP_VARIANTS, _fmt, _plant, search_boundary


@functools.cache
def ramp_boundary(config: str, rate: float, wpp: str = "IEC") -> dict:
    """The slow-ramp (quasi-static) run of ``config`` (report/f7_mechanism.py): its loss SCR, the
    record, and the states it passed every 0.1 of SCR (for the linearised check)."""
    return mech.ramp_run(_plant(CONFIGS[config], wpp), rate, np.round(np.arange(mech.RAMP_FROM, 1.0, -0.1), 3))


def _linearised(config: str, ramp: dict, at: dict[str, float | None]) -> dict[str, dict]:
    """The Jacobian's least-damped mode at the ramp's states nearest above each SCR of ``at``."""
    out = {}
    snaps = ramp["snapshots"]
    for label, scr in at.items():
        above = [s for s in snaps if scr is not None and s >= scr - 1e-9]
        if not above:
            continue
        s = min(above)
        state, q_wpp, q_order = snaps[s]
        plant = _plant(CONFIGS[config])
        plant.set_scr(s)
        plant.net.ensure()
        plant.tb.q_wpp[:] = q_wpp
        if len(state) != len(plant.state_real()):
            continue
        loop = mech.wpp_loop_modes(plant, q_wpp, q_order, state) if plant.wpp is not None else {}
        out[label] = {"scr": s, **mech.jacobian_modes(plant, state), "wpp_loop": loop}
    return out


def second_look(ctx: Context, val, traces, t_end: float, xtol: float) -> dict[str, str]:
    """Per case: the step boundary with the plant controller as before issue 39, the slow-ramp
    boundary (IEC and legacy controller), the mechanism of each loss and the linearised damping of
    the continuous plant at the step and ramp boundaries (report/f7_mechanism.py); the text for the
    findings, the numbers and the figure."""
    rate = mech.ramp_settings(ctx.quick)
    text, ramps, mechs = {}, {}, {}
    for n in F7_CONFIGS:
        legacy, legacy_runs = search_boundary(n, t_end, xtol, "stable", "legacy")
        ramp = {w: ramp_boundary(n, rate, w) for w in WPP_VARIANTS}
        ramps[n] = ramp
        lo = min(traces[n]["stable"]) if traces[n]["stable"] else None
        step_mech = "—" if lo is None else mech.mechanism(*_tv(traces[n]["stable"][lo]), T_EVENT + 1.0)
        ramp_mech = {w: "stable to the floor" if r["loss_t"] is None else
                     mech.mechanism(r["t"], r["v_pcc"], r["loss_t"] + LAST_S, r.get("v_wt")) for w, r in ramp.items()}
        mechs[n] = (step_mech, ramp_mech, val[n]["stable"], legacy.value)
        lin = _linearised(n, ramp["IEC"], {"step boundary": val[n]["stable"],
                                           "ramp boundary": None if ramp["IEC"]["loss_scr"] is None
                                           else ramp["IEC"]["loss_scr"] + 0.05})
        ctx.numbers[f"F7 second look {n}"] = {
            "step_boundary_iec": val[n]["stable"], "step_boundary_legacy_wpp": legacy.value,
            "ramp_boundary_iec": ramp["IEC"]["loss_scr"], "ramp_boundary_legacy_wpp": ramp["legacy"]["loss_scr"],
            "ramp_rate_per_s": rate, "step_mechanism": step_mech, "ramp_mechanism": ramp_mech, "linearised": lin}
        lin_txt = "; ".join(f"at the {k} (ramp state at SCR {m['scr']:.2f}, plant controller held): "
                            f"{mech.describe_modes(m)}"
                            + (f"; {mech.describe_wpp_loop(m['wpp_loop'])}" if m.get("wpp_loop") else "")
                            for k, m in lin.items())
        text[n] = (f"step boundary with the plant controller before issue 39: {_fmt(legacy.value)}; slow ramp "
                   f"({rate:g} SCR/s from {mech.RAMP_FROM:g}): IEC controller lost at {_fmt(ramp['IEC']['loss_scr'])}"
                   f" ({ramp_mech['IEC']}), legacy at {_fmt(ramp['legacy']['loss_scr'])} ({ramp_mech['legacy']}); "
                   f"below the step boundary: {step_mech}; linearised: {lin_txt or 'no ramp state'}")
    _f7_ramp_figure(ctx, ramps, mechs)
    return text


def _tv(r: dict) -> tuple:
    return r["t"], r["v_pcc"]


def _f7_ramp_figure(ctx: Context, ramps: dict[str, dict[str, dict]], mechs: dict[str, tuple]) -> None:
    fig, axes = figures.new(len(ramps), height_per_row=2.4, sharex=False)
    for ax, (name, by_wpp) in zip(axes[:, 0], ramps.items()):
        for w, style in zip(WPP_VARIANTS, ("-", "--")):
            r = by_wpp[w]
            loss = "stable to the floor" if r["loss_scr"] is None else f"lost at SCR {r['loss_scr']:.3f}"
            ax.plot(r["scr"], r["v_pcc"], ls=style, lw=0.7,
                    label=textwrap.fill(f"{name}, {w} plant controller, ramp: {loss}: {mechs[name][1][w]}", 110))
        step_mech, _, step_iec, step_legacy = mechs[name]
        for x, c in ((step_iec, "C3"), (step_legacy, "C7")):
            if x is not None:
                ax.axvline(x, color=c, ls="-.", lw=0.8)
        ax.set_title(textwrap.fill(f"{name}: step boundary (dash-dot) IEC {_fmt(step_iec)}, legacy {_fmt(step_legacy)}; "
                                   f"below the IEC one after the step: {step_mech}", 110), fontsize=7)
        for v in V_NORMAL:
            ax.axhline(v, color="0.5", ls=":", lw=0.8)
        ax.set_xlim(mech.RAMP_FROM, 1.0)
        ax.set_ylabel("|V_pcc| [p.u.]")
        ax.legend(fontsize=5.5, loc="lower left")
    axes[-1, 0].set_xlabel("SCR along the slow ramp (time runs left to right); after the loss the run goes on\n"
                           f"{mech.AFTER_LOSS_S:g} s at that SCR to show what the loss is", fontsize=8)
    figures.save(ctx, fig, "f7_ramp_boundaries", "F7's quasi-static boundaries: the SCR lowered slowly "
                 "(report/f7_mechanism.py); the step boundaries are in f7_weak_grid_boundaries.",
                 prefix="Testbed (issue 39): ")
