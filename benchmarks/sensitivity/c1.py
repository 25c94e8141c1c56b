"""C1.b's offline analogue for the claim sensitivity study (report/exp_cyber.py measures it through
the network): a plugged SDViSC's current and voltage settling."""

from __future__ import annotations

from benchmarks.sensitivity.common import apply, split
from plant.params import PlantParams
from plant.sim import Plant
from report.network_runs import settle_time
from sdc_unit.params import ViscParams

C1_T_PLUG, C1_T_END, C1_WT = 1.2, 3.2, 0  # wt1_1 (cluster 1's first turbine) at 1.2 s, as the scenario


def eval_c1(changes: dict) -> dict:
    """C1.b offline: the full farm (SC in service, as PlantParams() the network plant uses), turbine
    wt1_1 to the continuous ViSC law (hd_visc, H 3 s as the scenario) at 1.2 s; settling of |i| and
    the terminal |V| as report/exp_cyber.py measures it (within 0.02 p.u. of their mean over the last 0.3 s)."""
    plant_ch, visc, case = split(changes)
    pp = apply(PlantParams(), plant_ch)
    pp.visc_params = ViscParams(**{"h": 3.0, **visc})
    p = Plant(pp)
    if case.get("p_before_zero"):
        p.set_power_ref([C1_WT], p=0.0)
        p.reinitialise()
    r = p.run_offline(C1_T_END, events=[(C1_T_PLUG, lambda q: q.set_mode([C1_WT], "hd_visc"))], record_every=3)
    t, i, v = r["t"], r["i_wt"][:, C1_WT], r["v_wt"][:, C1_WT]  # what the paper names: current and voltage
    out = {}
    for band in (0.02, 0.05):
        out[f"settle band {band:g}"] = max(settle_time(t, i, C1_T_PLUG, C1_T_END, band),
                                           settle_time(t, v, C1_T_PLUG, C1_T_END, band))
    out["p_before_after"] = (float(r["p_wt"][t < C1_T_PLUG][-1, C1_WT]), float(r["p_wt"][-1, C1_WT]))
    return out
