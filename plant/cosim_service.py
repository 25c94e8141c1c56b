"""Offline co-simulation under the conditions of a network run (``plant.service`` + ``sdc_unit.service``).

:mod:`plant.cosim` runs the paper's case as the paper sets it up (ViSC turbines at P* = 0 from t = 0,
controller initialised at t = 0). A network run (``scenarios/fault_4visc_network.yaml``) starts
differently; this module reproduces what the service path does, step by step, without a network:

* the model is the one :func:`plant.service.model.build_model` builds: ``PlantParams()`` with
  ``remote_apply = "v_ref"``, 50 turbines, all grid-following on the MPPT curve from t = 0 (wind
  12 m/s, above rated: P = 1 p.u.), the remote-loss fall-back and the over-current trip enabled;
* a ViSC turbine switches to ``remote`` when its ``STREAM_START`` arrives, in the plant's iteration
  ``start_step`` before that step (``set_mode``: the present converter voltage is held, bumpless);
  the first ``MEAS`` (seq 1) carries the state after that step, seq m the state at step
  ``start_step + m``;
* the SDC is :class:`sdc_unit.bank.ControllerBank` (what ``sdc_unit.service`` steps through
  :func:`sdc_unit.round.step_round`): ``ViscParams()`` plus the ``START`` request's parameters
  (``{h: 3.0}``, the default), initialised on the first MEAS it uses (bumpless, from the turbine's
  operating point, then stepped on it), one step per MEAS, in order. Its ``p_ref`` is 0, so after
  the start the ViSC takes the turbine from 1 p.u. active power to 0;
* MEAS and CTRL values are float32 on the wire (``quantise``);
* the CTRL answering MEAS seq c is applied before the plant's step of iteration
  ``start_step + c + lag - 1`` (``lag`` = the round trip in samples of ``summary.json``'s
  ``round_trip_samples``; 1 = the answer to the last MEAS drives the next step, which is
  :func:`plant.cosim.run_sdc` with ``delay_samples = 0``) and held until a newer one arrives;
  ``lag`` is one number for every step, or per step and turbine the recorded
  ``timeseries.csv`` ``<wt>.ctrl_lag`` column (an exact replay of the run's delivery);
* scenario events (fault on/off) are applied in the iteration the plant read them, before its step.

:func:`run_service_hd` is the hardware-dependent ViSC under the same conditions (the continuous law
inside the plant, switched on at the first start step). Traces are those of :mod:`plant.cosim`
(rows after each step, time (k + 1)·Ts) plus ``i_wt`` (converter current magnitude) and ``p_wt``
(active power), p.u. per ViSC turbine;
:func:`compare_window` compares any two over a time window relative to a reference's range.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from plant.cosim import QUANTITIES
from plant.params import PlantParams
from plant.sim import Plant
from sdc_unit.bank import ControllerBank
from sdc_unit.params import ViscParams
from sdvisc.vocabulary import MEAS_FIELDS, VISC_PARAMS, mask_of


@dataclass(frozen=True)
class ServiceConditions:
    """When things happened in a network run, in plant iterations (step k advances k·Ts → (k+1)·Ts)."""

    visc_turbines: tuple[int, ...] = (0, 10, 20, 30)
    start_steps: tuple[int, ...] = (299, 299, 299, 299)
    """Per ViSC turbine: the iteration whose receive step carried ``STREAM_START``."""
    first_used_seq: tuple[int, ...] = (1, 1, 1, 1)
    """Per ViSC turbine: the MEAS seq the SDC initialised on (> 1 when START reached it late)."""
    fault_steps: tuple[tuple[int, bool], ...] = ((1493, True), (1940, False))
    """(iteration, on) of each fault event."""
    n_steps: int = 4478
    step_s: float = 0.67e-3
    n_turbines: int = 50
    params: dict = field(default_factory=lambda: {"h": 3.0})
    """The START request's ViSC parameters."""
    law: str = "visc"
    """The SDC's law (sdc_unit.laws.LAWS)."""
    method: str = "tustin"
    dtype: str = "float64"
    p_star: float | None = None
    """None: grid-following P* from the MPPT curve until the start (the service); a number: P* of the
    ViSC turbines from t = 0 (the paper's set-up, as :mod:`plant.cosim`)."""


def _plant(cond: ServiceConditions):
    base = PlantParams()
    params = replace(base, turbine=replace(base.turbine, remote_apply="v_ref"))
    plant = Plant(params, n_turbines=cond.n_turbines, step_s=cond.step_s)
    idx = np.asarray(cond.visc_turbines)
    if cond.p_star is not None:
        plant.set_power_ref(idx, p=cond.p_star)
        plant.reinitialise()
    return plant, idx


def _faults(plant, k: int, cond: ServiceConditions) -> None:
    for step, on in cond.fault_steps:
        if step == k:
            plant.fault(on)


def _lag_table(lag, n_steps: int, n_visc: int) -> np.ndarray:
    table = np.broadcast_to(np.asarray(lag, dtype=np.int64), (n_steps, n_visc)) if np.ndim(lag) < 2 else np.asarray(lag)
    if table.shape[0] < n_steps or table.shape[1] != n_visc:
        raise ValueError(f"lag needs {n_steps} steps x {n_visc} turbines, got {table.shape}")
    return table


def run_service_sdc(cond: ServiceConditions = ServiceConditions(), lag=1, quantise: bool = True,
                    meas_after_events: bool = False) -> dict[str, np.ndarray]:
    """The SDC loop of a network run, offline (see the module docstring). ``lag``: round trip in
    samples (>= 1), one number or an (n_steps, n_visc) table (0 there = no CTRL applied yet).
    ``meas_after_events``: the SDC's sample of a step is taken after that step's events, as
    :func:`plant.cosim.run_sdc` does (it sees a fault in the step it is applied; the service's MEAS
    left before, so the service sees it one sample later)."""
    plant, idx = _plant(cond)
    n_visc = len(idx)
    lags = _lag_table(lag, cond.n_steps, n_visc)
    bank = ControllerBank(n_visc, cond.step_s, method=cond.method, dtype=cond.dtype, law=cond.law)
    start = np.asarray(cond.start_steps)
    first = np.asarray(cond.first_used_seq)
    start_request = {"mask": mask_of(cond.params), **{k: float(v) for k, v in cond.params.items() if k in VISC_PARAMS}}
    outputs: list[dict[int, tuple]] = [{} for _ in range(n_visc)]  # per turbine: seq -> (v_ref, delta, e_mag)
    applied = np.zeros(n_visc, dtype=np.int64)  # seq of the CTRL in force (0: none)
    last_delta = np.full(n_visc, np.nan)
    last_e = np.full(n_visc, np.nan)
    f32 = (lambda a: np.asarray(a, dtype=np.float32).astype(float)) if quantise else (lambda a: np.asarray(a, dtype=float))
    rows = []
    for k in range(cond.n_steps):
        # the MEAS of the present state (seq <= 0: not streaming yet) left at the end of the last
        # iteration, before this iteration's events (a fault reaches the SDC one sample later)
        seq = k - start
        used = np.nonzero(seq >= first)[0]
        meas = plant.measurements() if used.size and not meas_after_events else None
        _faults(plant, k, cond)
        if used.size and meas_after_events:
            meas = plant.measurements()
        for j in np.nonzero(start == k)[0]:
            plant.set_mode(idx[j], "remote")
            bank.start(j, dict(start_request))
        if used.size:
            out, valid = bank.step(used, {f: f32(meas[f][idx[used]]) for f in MEAS_FIELDS})
            for r, j in enumerate(used):
                if valid[r]:
                    outputs[j][int(seq[j])] = (f32(out["v_ref_d"][r]), f32(out["v_ref_q"][r]),
                                               f32(out["delta"][r]), f32(out["e_mag"][r]))
        for j in range(n_visc):
            if lags[k, j] <= 0 or k < start[j]:
                continue
            c = int(k + 1 - start[j] - lags[k, j])  # the seq of the CTRL in force in this step
            if c > applied[j] and c in outputs[j]:
                v_d, v_q, last_delta[j], last_e[j] = outputs[j][c]
                plant.apply_remote(idx[j:j + 1], [v_d], [v_q])
                applied[j] = c
                for old in [s for s in outputs[j] if s < c]:
                    del outputs[j][old]
        plant.step()
        o = plant.outputs()
        rows.append((o["v_pcc"], o["q_wt"][idx], last_delta.copy(), last_e.copy(), o["i_wt"][idx], o["p_wt"][idx]))
    res = _stack(rows, cond)
    res["trips"] = plant.trips[idx].copy()
    return res


def run_service_hd(cond: ServiceConditions = ServiceConditions()) -> dict[str, np.ndarray]:
    """The hardware-dependent ViSC under the network run's conditions, switched on for every ViSC
    turbine at the first start step (same parameters as the SDC's)."""
    plant, idx = _plant(cond)
    plant.set_visc_params(ViscParams().with_changes(**cond.params))
    t_on = min(cond.start_steps)
    nan = np.full(len(idx), np.nan)
    rows = []
    for k in range(cond.n_steps):
        _faults(plant, k, cond)
        if k == t_on:
            plant.set_mode(idx, "hd_visc")
        plant.step()
        o = plant.outputs()
        on = k >= t_on
        rows.append((o["v_pcc"], o["q_wt"][idx], o["visc_delta"][idx] if on else nan,
                     o["visc_e"][idx] if on else nan, o["i_wt"][idx], o["p_wt"][idx]))
    res = _stack(rows, cond)
    res["trips"] = plant.trips[idx].copy()
    return res


def unwrap_finite(angle: np.ndarray) -> np.ndarray:
    """Unwrap each column over its finite samples (nan before a controller started stays nan)."""
    out = np.array(angle, dtype=float)
    for j in range(out.shape[1]):
        ok = np.isfinite(out[:, j])
        out[ok, j] = np.unwrap(out[ok, j])
    return out


def _stack(rows, cond: ServiceConditions) -> dict[str, np.ndarray]:
    names = (*QUANTITIES, "i_wt", "p_wt")
    out = {name: np.array([r[j] for r in rows], dtype=float) for j, name in enumerate(names)}
    out["v_pcc"] = out["v_pcc"][:, None]
    out["delta"] = unwrap_finite(out["delta"])
    out["t"] = (np.arange(len(rows)) + 1) * cond.step_s
    return out


def compare_window(trace: dict, other: dict, reference: dict, t_from: float, t_to: float) -> dict[str, dict[str, float]]:
    """Per quantity, worst over turbines: RMS of ``trace - other`` over ``t_from <= t <= t_to`` and
    that RMS relative to the range of ``reference`` over the same window [%], both over the samples
    where all three are defined. The three share the time base (rows after each step) and δ's frame
    (the plant's common frame)."""
    t = reference["t"]
    n = min(len(trace["t"]), len(other["t"]), len(t))
    if not (np.allclose(trace["t"][:n], t[:n]) and np.allclose(other["t"][:n], t[:n])):
        raise ValueError("the traces are not on the same time base")
    window = (t[:n] >= t_from - 1e-9) & (t[:n] <= t_to + 1e-9)
    res = {}
    for name in QUANTITIES:
        a, b, ref = trace[name][:n][window], other[name][:n][window], reference[name][:n][window]
        both = np.isfinite(a) & np.isfinite(b) & np.isfinite(ref)  # δ, E: from a controller's start
        if not both.any(axis=0).all():
            raise ValueError(f"{name}: no sample in the window where all three traces are defined")
        rms = np.sqrt(np.nanmean(np.where(both, (a - b) ** 2, np.nan), axis=0))
        span = np.nanmax(np.where(both, ref, np.nan), axis=0) - np.nanmin(np.where(both, ref, np.nan), axis=0)
        res[name] = {"rms": float(np.max(rms)), "rms_over_range_pct": float(100 * np.max(rms / span)),
                     "reference_range": float(np.min(span))}
    return res
