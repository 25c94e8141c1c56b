"""Programmable H at run time (issue 28 item 8), the runs behind report F4h and F4hnet: the case of
scenarios/paper/f4_programmable_h.yaml (four SDViSCs of cluster 3, H 3 s, +50 MW, an OWFCC
``set_params {h: 5}``, a second +50 MW) offline, and what is measured on each load step.

Offline the SDViSCs are the SDC's own controller bank (:class:`sdc_unit.bank.ControllerBank`, the
Tustin SDC the SDC service steps) closing the loop through the plant's ``remote`` mode, one sample of
round trip (the answer to a MEAS drives the next plant step), switched on at the file's ``visc_on``
time at P* = 0 as through the network; the OWFCC request is ``ControllerBank.set_params`` with the
request's mask and value, the call the SDC service makes when the request arrives
(sdc_unit/service.py). A cross-check runs the continuous law inside the plant (``hd_visc``) with
``Plant.set_visc_params``. A control run keeps H 3 s: the second step's change against it is H's
effect alone (the first and the second step do not start from the same operating point).
"""

from __future__ import annotations

import numpy as np
from scipy.signal import detrend, periodogram

from plant.cases import visc_indices, visc_plant
from report import network_runs
from sdc_unit.bank import ControllerBank
from sdc_unit.params import ViscParams
from sdvisc.config import GRID_SCENARIO_KEYS
from sdvisc.vocabulary import MEAS_FIELDS, mask_of

NAME = "f4_programmable_h"
RECORD_EVERY = 5  # plant steps per recorded sample offline (3.35 ms)
PRE_EVENT_S = 0.1  # the frequency before an event: its mean over this long before it
END_MARGIN_S = 0.02  # a window ends this long before the next event (its sample may already show it)


def case() -> dict:
    """What the scenario file sets: grid keys (GridParams names), the turbines, H before (visc_on)
    and after (set_params), when, the load steps [(t, MW)], the duration."""
    sc = network_runs.load(NAME)
    plant = sc["plant"]
    visc = [e for e in sc["timeline"] if e["do"] == "visc_on"]
    sets = [e for e in sc["timeline"] if e["do"] == "set_params" and "h" in e["params"]]
    if len({e["t"] for e in sets}) != 1 or {e["wt"] for e in sets} != {e["wt"] for e in visc}:
        raise ValueError(f"{NAME}: one set_params of h to every SDViSC at one time expected")
    if len({e["t"] for e in visc}) != 1:
        raise ValueError(f"{NAME}: the SDViSCs are switched on at one time")
    return {"grid": {GRID_SCENARIO_KEYS[k]: v for k, v in (plant.get("grid") or {}).items()},
            "turbines": [e["wt"] for e in visc], "t_on": float(visc[0]["t"]),
            "h_before": float(visc[0].get("params", {}).get("h", ViscParams().h)),
            "h_after": float(sets[0]["params"]["h"]), "t_set": float(sets[0]["t"]),
            "loads": [(float(e["t"]), float(e["mw"])) for e in sc["timeline"] if e["do"] == "load_step"],
            "duration_s": float(sc["duration_s"])}


def run_sdc(c: dict, switch: bool = True) -> dict[str, np.ndarray]:
    """The case with the SDC's controller bank (see the module docstring); ``switch=False`` keeps H
    at ``h_before`` (the control run). PCC frequency [Hz] and the SDViSCs' mean P [p.u.] against t."""
    idx = visc_indices(len(c["turbines"]))
    plant = visc_plant(len(idx), activate=False, **c["grid"])  # at P* = 0, grid-following until t_on
    plant.set_remote_fallback(False)
    bank = ControllerBank(len(idx), plant.step_s, method="tustin")
    slots = np.arange(len(idx))
    request = {"mask": mask_of({"h": c["h_after"]}), "h": c["h_after"]}  # what the SDC's REQUEST carries
    actions = sorted([(t, "load", mw) for t, mw in c["loads"]] + [(c["t_on"], "on", None)]
                     + ([(c["t_set"], "set", None)] if switch else []), key=lambda a: a[0])
    n_steps = int(round(c["duration_s"] / plant.step_s))
    on = False
    t_rec, f_rec, p_rec = [], [], []
    for k in range(n_steps):
        t = k * plant.step_s
        while actions and actions[0][0] <= t + 0.5 * plant.step_s:
            _, what, mw = actions.pop(0)
            if what == "load":
                plant.load_step(mw)
            elif what == "on":
                plant.set_mode(idx, "remote")
                for j in slots:
                    bank.start(j, {"mask": mask_of({"h": c["h_before"]}), "h": c["h_before"]})
                on = True
            else:
                for j in slots:
                    bank.set_params(j, dict(request))
        if on:
            meas = plant.measurements()
            out, _ = bank.step(slots, {f: np.asarray(meas[f], dtype=np.float32)[idx] for f in MEAS_FIELDS})
            plant.apply_remote(idx, out["v_ref_d"], out["v_ref_q"])
        if k % RECORD_EVERY == 0:
            rec = plant.recorded()
            t_rec.append(rec["t"])
            f_rec.append(rec["f_pcc_hz"])
            p_rec.append(float(np.mean(rec["p"][idx])))
        plant.step()
    h_now = bank.runtime_params(0)["h"]
    return {"t": np.array(t_rec), "f": np.array(f_rec), "p_visc": np.array(p_rec), "h_end": h_now}


def run_hd(c: dict, switch: bool = True) -> dict[str, np.ndarray]:
    """The same case with the continuous law inside the plant (hd_visc, from t = 0), the H change
    by ``Plant.set_visc_params``."""
    idx = visc_indices(len(c["turbines"]))
    plant = visc_plant(len(idx), visc_params=ViscParams(h=c["h_before"]), **c["grid"])
    events = [(t, lambda q, mw=mw: q.load_step(mw)) for t, mw in c["loads"]]
    if switch:
        events.append((c["t_set"], lambda q: q.set_visc_params(ViscParams(h=c["h_after"]))))
    r = plant.run_offline(c["duration_s"], events=events, record_every=RECORD_EVERY)
    return {"t": r["t"], "f": r["f_pcc_hz"], "p_visc": r["p_wt"][:, idx].mean(axis=1)}


def event_windows(c: dict, t_end: float) -> list[tuple[float, float]]:
    """Each load step's window, all as long as the shortest gap to the next step (or the end), less
    END_MARGIN_S: the same length for each step (the periodograms' resolution), none sees the next."""
    starts = [t for t, _ in c["loads"]]
    length = min(b - a for a, b in zip(starts, starts[1:] + [t_end])) - END_MARGIN_S
    return [(t0, t0 + length) for t0 in starts]


def event_metrics(t: np.ndarray, f: np.ndarray, t0: float, t1: float) -> dict[str, float]:
    """What a load step at ``t0`` did to the PCC frequency ``f`` [Hz] until ``t1``: the nadir (lowest
    f − 50 Hz), the dip (lowest f − the mean over PRE_EVENT_S before t0, less the END_MARGIN_S just
    before it: an offline step is applied half a plant step early and recorded there), when the lowest point came
    (after t0) and the dominant oscillation frequency: the largest peak of the zero-padded
    periodogram of the detrended frequency over the window (as F4)."""
    before = (t >= t0 - PRE_EVENT_S) & (t < t0 - END_MARGIN_S)  # a sample just before t0 may show the step
    inside = (t >= t0) & (t < t1)
    tw, fw = t[inside], f[inside]
    low = int(np.argmin(fw))
    osc = detrend(fw)
    freqs, power = periodogram(osc, fs=1.0 / float(np.median(np.diff(tw))), nfft=16 * len(osc))
    return {"nadir_hz": float(fw[low] - 50.0), "dip_hz": float(fw[low] - np.mean(f[before])),
            "t_nadir_s": float(tw[low] - t0), "osc_hz": float(freqs[1:][np.argmax(power[1:])]),
            "window_s": float(t1 - t0)}


def events_of(run: dict, c: dict) -> list[dict[str, float]]:
    t_end = float(run["t"][-1])
    return [event_metrics(run["t"], run["f"], t0, t1) for t0, t1 in event_windows(c, t_end)]


def inertia_mws(c: dict, turbine_mva: float = 10.0) -> dict[str, float]:
    """The stored energies behind the comparison [MWs]: the SDViSCs' at H before and after, the grid
    source's (H on its rating)."""
    n = len(c["turbines"])
    return {"visc_before": n * turbine_mva * c["h_before"], "visc_after": n * turbine_mva * c["h_after"],
            "grid": c["grid"].get("h_grid", 0.0) * c["grid"].get("s_grid_mva", 0.0)}
