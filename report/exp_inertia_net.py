"""F5net: the paper's SDViSC + battery case of F5 (+100 MW, H 4 s, 2000 Ah battery, grid source
with inertia) through the network, scenarios/paper/f5_inertia_100mw_battery.yaml at the auto time
scale, beside the same case offline (hd_visc, report/exp_grid.py's F5 set-up with the file's
grid, H, batteries and load step). By default the paper's comparison arrangement (the onshore
40 MVA SDViSC, host wt6_1, against ``plant.cases.comparison_visc_plant``), with
``--net-arrangement cluster3`` the four SDViSCs of cluster 3 (report/net_arrangement.py). The
frequency nadirs are compared with a stated tolerance."""

from __future__ import annotations

from plant.params import BatteryParams
from report import figures, net_arrangement, network_runs
from report.exp_grid import _load_step
from report.registry import CONSISTENCY, Context, Experiment, Finding, PaperClaim
from report.verdicts import close_to, holds
from sdc_unit.params import ViscParams
from sdvisc.config import GRID_SCENARIO_KEYS

NAME = "f5_inertia_100mw_battery"
NADIR_YES, NADIR_PARTLY = 0.10, 0.35  # |nadir_network - nadir_offline| / |nadir_offline| (the report's usual rule)

F5NET_CLAIMS = (
    PaperClaim("F5net.a", "+100 MW load, SDViSCs (H 4 s) with a 2000 Ah battery on the DC link — with the SDC "
               "over the network: the frequency dip is the one of the same case offline", "nadir as offline",
               kind=CONSISTENCY),
    PaperClaim("F5net.b", "A 2000 Ah Li-ion battery on the DC link clearly reduces the SDViSC's frequency dip — the "
               "network run with batteries against the SDViSCs without them (offline)", "obviously smaller nadir"),
)


def case() -> dict:
    """What the scenario file sets: grid keys (GridParams names), ViSC H, the battery turbines and
    SOC, the load step (MW, s)."""
    sc = network_runs.load(net_arrangement.scenario(NAME))
    plant = sc["plant"]
    visc = [e for e in sc["timeline"] if e["do"] == "visc_on"]
    load = next(e for e in sc["timeline"] if e["do"] == "load_step")
    batteries = plant.get("batteries") or {}
    return {"grid": {GRID_SCENARIO_KEYS[k]: v for k, v in (plant.get("grid") or {}).items()},
            "h": float(visc[0].get("params", {}).get("h", ViscParams().h)), "n_visc": len(visc),
            "batteries": batteries.get("turbines", []),
            "soc_init": batteries.get("soc_init", BatteryParams.soc_init),
            "mw": float(load["mw"]), "t_load": float(load["t"]), "duration_s": float(sc["duration_s"])}


def _f5net(ctx: Context) -> dict[str, Finding]:
    c = case()
    if c["t_load"] != 1.0:
        raise ValueError(f"{NAME}: the offline case steps the load at 1 s, the file at {c['t_load']} s")
    summary, ts = network_runs.run(ctx, net_arrangement.scenario(NAME))
    t, f = ts["t"], ts["f_pcc_hz"]
    after = t > c["t_load"]
    nadir_net = float(f[after].min() - 50.0)
    vp = ViscParams(h=c["h"])
    idx = net_arrangement.indices()
    if len(idx) != c["n_visc"]:
        raise ValueError(f"{net_arrangement.scenario(NAME)}: {c['n_visc']} SDViSCs, the offline case has {len(idx)}")
    offline = _load_step(net_arrangement.offline_plant(visc_params=vp, battery=True, **c["grid"]), c["mw"],
                         c["duration_s"], visc=idx)
    no_batt = _load_step(net_arrangement.offline_plant(visc_params=vp, **c["grid"]), c["mw"], c["duration_s"], visc=idx)
    batt = summary.get("batteries", {})
    soc_net = {wt: b["soc_change"] for wt, b in batt.items()}
    worst_soc = min(soc_net.values(), default=0.0)
    trips = summary.get("converter_trips") or {}
    fallbacks = summary.get("fallbacks") or {}
    err = abs(nadir_net - offline["nadir_hz"]) / abs(offline["nadir_hz"])
    verdict = close_to(nadir_net, offline["nadir_hz"], NADIR_YES, NADIR_PARTLY)
    if trips or fallbacks:
        verdict = "no"
    k = summary.get("time", {}).get("time_scale")
    ctx.numbers["f5net"] = {"nadir_network_hz": nadir_net, "nadir_offline_hz": offline["nadir_hz"],
                            "nadir_offline_no_battery_hz": no_batt["nadir_hz"], "relative_error": err,
                            "soc_change_network": soc_net, "soc_change_offline": -offline["d_soc"],
                            "time_scale": k, "late_steps": summary.get("late_steps"), "steps": summary.get("steps")}
    a = Finding(
        f"nadir network {nadir_net:+.4f} Hz, offline {offline['nadir_hz']:+.4f} Hz ({err:.1%} apart)", verdict,
        f"tolerance: within {NADIR_YES:.0%} of the offline nadir = yes, {NADIR_PARTLY:.0%} partly; a converter trip "
        f"or fall-back = no (trips {trips or 'none'}, fall-backs {fallbacks or 'none'}). Offline: the same case with "
        f"the law inside the plant (hd_visc) from t = 0 at P* = 0, the network run switches {net_arrangement.label()} "
        f"to the SDC at 0.2 s (also at P* = 0); time scale {k}, {summary.get('late_steps')} of {summary.get('steps')} steps late. "
        "SOC change per battery: network " + ", ".join(f"{wt} {d * 100:+.3f} %" for wt, d in soc_net.items())
        + f", offline {-offline['d_soc'] * 100:+.3f} %",
        {"nadir_network_hz": nadir_net, "nadir_offline_hz": offline["nadir_hz"], "relative_error": err})
    gain = nadir_net - no_batt["nadir_hz"]
    b = Finding(
        f"nadir {no_batt['nadir_hz']:+.4f} Hz without battery (offline) → {nadir_net:+.4f} Hz with it (network); "
        f"SOC {worst_soc * 100:+.3f} %", holds(gain >= 0.05 * abs(no_batt["nadir_hz"]) and worst_soc < 0,
                                               partly=gain > 0),
        "clear = ≥ 5 % of the nadir and the batteries' SOC fell (they gave the energy); as F5.b, with the batteries' "
        "SDViSCs stepped over the network", {"gain_hz": gain, "soc_change": soc_net})
    fig, axes = figures.new(2)
    ax = axes[0, 0]
    ax.plot(no_batt["t"], no_batt["f"], "0.5", lw=1.0, label=f"offline, no battery (nadir {no_batt['nadir_hz']:+.3f} Hz)")
    ax.plot(offline["t"], offline["f"], "k", lw=1.5, label=f"offline, battery (nadir {offline['nadir_hz']:+.3f} Hz)")
    ax.plot(t, f, "C1--", lw=1.0, label=f"network, battery, k = {k} (nadir {nadir_net:+.3f} Hz)")
    ax.set_ylabel("PCC frequency [Hz]")
    ax.legend(fontsize=7)
    ax = axes[1, 0]
    for wt in c["batteries"]:
        if f"{wt}.soc" in ts:
            ax.plot(t, (ts[f"{wt}.soc"] - c["soc_init"]) * 100, lw=1.0, label=f"{wt} (network)")
    ax.set_ylabel("SOC change [%]")
    ax.legend(fontsize=7)
    for ax in axes[:, 0]:
        ax.axvline(c["t_load"], color="C3", ls=":", lw=0.9)
    axes[-1, 0].set_xlabel(f"t [s] (+{c['mw']:g} MW at {c['t_load']:g} s; grid source H {c['grid'].get('h_grid', 0):g} s "
                           f"on {c['grid'].get('s_grid_mva', 0):g} MVA, assumed)")
    figures.save(ctx, fig, "f5net_battery_through_network", "a 2000 Ah battery on the DC link obviously reduces the "
                 "SDViSC's frequency dip.")
    return {"F5net.a": a, "F5net.b": b}


F5NET = Experiment("F5net", "F5 through the network: SDViSC + battery, +100 MW", "Fig. Compare_inertia3", "cyber",
                   F5NET_CLAIMS, _f5net, network_runs.command(NAME),
                   f"{net_arrangement.DESCRIPTION}; with a 2000 Ah battery on the DC link; grid source H 5 s on "
                   "1000 MVA (assumed).")
