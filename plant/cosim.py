"""Offline co-simulation of the discretised SDViSC with the full wind-farm plant (no network).

The paper's validation case: turbines of the 50-turbine farm run as ViSC, a single-phase-to-ground
fault at the PCC at 1.0 s is cleared at 1.3 s, and the software-defined controller (Tustin at
Ts = 0.67 ms) is compared with the hardware-dependent ViSC (the continuous law evaluated inside the
plant at its internal step). Here the SDC is a :class:`~sdc_unit.discrete.DiscreteVisc` stepped
once per plant step on the plant's measurements, its converter-voltage reference applied by the
plant's ``remote`` mode (``remote_apply = "v_ref"``: the SDC closes the inner current loop too)
after ``delay_samples`` samples -- 0 = the ideal sampled controller, 1 = one sample of transport
(the network round trip the testbed measures is ~1–3 ms, i.e. 2–5 samples; see docs/sdc.md).
``remote_apply = "i_ref"`` applies the SDC's limited current reference through the converter's own
current loop instead. The plant may step ``plant_steps_per_sample`` times per sample (the SDC's
output held in between: a sampled controller on a finer plant step). A run records the converter
trips of the ViSC turbines and stops, padding with NaN, when the plant's values stop being finite.
A step's row is read from ``Plant.recorded()`` (and the hd_visc law's outputs), not ``outputs()``: the
same values without its full node-voltage solve (docs/plant.md, the recorder of 2026-12-02).

``compare`` returns, per quantity, the RMS deviation from the HD run and that RMS relative to the
range of the HD trace (the 1 % criterion of the issue).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from types import SimpleNamespace

import numpy as np

from plant.params import PlantParams
from plant.sim import Plant
from sdc_unit.discrete import DiscreteVisc
from sdc_unit.laws import get_law
from sdc_unit.params import ViscParams
from sdvisc.vocabulary import CTRL_OUTPUTS, MEAS_FIELDS, REMOTE_REFERENCES

QUANTITIES = ("v_pcc", "q", "delta", "e_mag")


@dataclass(frozen=True)
class FaultCase:
    """The paper's case: which turbines are ViSC, when the fault is applied and cleared [s]."""

    visc_turbines: tuple[int, ...] = (0, 10, 20, 30)  # one per cluster of the first four
    t_fault_s: float = 1.0
    t_clear_s: float = 1.3
    t_end_s: float = 2.0
    step_s: float = 0.67e-3  # the SDC's sampling period Ts
    n_turbines: int = 50
    plant_steps_per_sample: int = 1  # the plant steps Ts / this (the HD ViSC too)

    @property
    def plant_step_s(self) -> float:
        return self.step_s / self.plant_steps_per_sample

    @property
    def n_steps(self) -> int:
        """Plant steps of the run."""
        return int(round(self.t_end_s / self.plant_step_s))


def samples_for_delay(delay_s: float, ts: float) -> int:
    """A CTRL delayed by ``delay_s`` is applied at the first sample at or after its arrival: held
    ceil(delay / Ts) samples (0 for no delay; a part of a nanosecond is not a sample)."""
    if delay_s < 0:
        raise ValueError(f"negative delay {delay_s}")
    return max(0, math.ceil(delay_s / ts - 1e-6))


def _plant(case: FaultCase, remote_apply: str = "v_ref"):
    if remote_apply not in ("v_ref", "i_ref"):
        raise ValueError(f"remote_apply {remote_apply!r}: 'v_ref' or 'i_ref'")
    base = PlantParams()
    params = replace(base, turbine=replace(base.turbine, remote_apply=remote_apply))
    plant = Plant(params, n_turbines=case.n_turbines, step_s=case.plant_step_s)
    idx = np.asarray(case.visc_turbines)
    plant.set_power_ref(idx, p=0.0)  # ViSC turbines as condensers (no active power), as in the paper
    plant.reinitialise()
    return plant, idx


def _events(plant, k: int, case: FaultCase) -> None:
    h = case.plant_step_s
    t = k * h
    if abs(t - case.t_fault_s) < h / 2:
        plant.fault(True)
    if abs(t - case.t_clear_s) < h / 2:
        plant.fault(False)


def run_hd(case: FaultCase = FaultCase(), visc_params: ViscParams | None = None) -> dict[str, np.ndarray]:
    """The continuous ViSC law inside the plant (``hd_visc``) at the case's plant step with ``visc_params``
    (default ``ViscParams()``, the SDC's own: the same law the SDC discretises, a consistency check; the
    paper's HD reference is :func:`plant.hd_reference.run_reference`): traces (time x turbine) of v_pcc, q,
    delta and e_mag."""
    plant, idx = _plant(case)
    if visc_params is not None:
        plant.set_visc_params(visc_params)
    plant.set_mode(idx, "hd_visc")
    pos = _law_positions(plant, idx)
    rows = []
    for k in range(case.n_steps):
        _events(plant, k, case)
        plant.step()
        rec = plant.recorded()
        delta, e_mag = _law_traces(plant, pos)
        rows.append((rec["v_pcc"], rec["q"][idx], delta, e_mag))
        if not np.isfinite(rows[-1][0]):
            break
    return _stack(rows, case)


def run_sdc(case: FaultCase = FaultCase(), method: str = "tustin", dtype=np.float64,
            delay_samples: int = 0, remote_apply: str = "v_ref",
            visc_params: ViscParams | None = None) -> dict[str, np.ndarray]:
    """The software-defined ViSC (``method``, ``dtype``) closing the loop through the plant's remote
    mode (``remote_apply``) with ``delay_samples`` of transport (the CTRL held at the turbine);
    ``visc_params`` default ``ViscParams()``; same traces as :func:`run_hd`, plus ``trips`` (per ViSC turbine) and ``trip_t`` (the first trip [s]
    or NaN)."""
    plant, idx = _plant(case, remote_apply)
    plant.set_mode(idx, "remote")
    plant.set_remote_fallback(False)
    ctrl = DiscreteVisc(len(idx), visc_params or ViscParams(), ts=case.step_s, method=method, dtype=dtype)
    ctrl.initialise(np.arange(len(idx)), _meas(plant, idx))
    last = ctrl.last
    refs = tuple(np.array(last[k], dtype=float) for k in ("v_ref_d", "v_ref_q", "i_ref_d", "i_ref_q"))
    queue = [refs] * delay_samples
    m = case.plant_steps_per_sample
    rows = []
    trip_t = math.nan
    o = None
    for k in range(case.n_steps):
        _events(plant, k, case)
        if k % m == 0:
            o = ctrl.step(_meas(plant, idx))
            queue.append((o.v_ref_d, o.v_ref_q, o.i_ref_d, o.i_ref_q))
            plant.apply_remote(idx, *queue.pop(0))
        plant.step()
        trip_t = _record(plant, idx, k, case, rows, trip_t, o.delta, o.e_mag)
        if not np.isfinite(rows[-1][0]):
            break
    return _with_trips(_stack(rows, case), plant, idx, trip_t)


def run_law(case: FaultCase = FaultCase(), law: str = "visc", delay_samples: int = 0,
            remote_apply: str = "v_ref") -> dict[str, np.ndarray]:
    """Any law of :data:`sdc_unit.laws.LAWS` as the SDC runs it (its bank: the ViSC's hand-derived
    Tustin, another law's generic trapezoid) sampled every ``case.step_s``, closing the loop through
    the plant's remote mode as :func:`run_sdc`; same traces (delta and e_mag from the law's CTRL
    outputs). With ``case.step_s`` at the plant's step (HD_STEP_S) it is that law's HD reference
    (:func:`plant.hd_reference.run_law_reference`)."""
    plant, idx = _plant(case, remote_apply)
    plant.set_mode(idx, "remote")
    plant.set_remote_fallback(False)
    n = len(idx)
    ctrl = get_law(law).bank(n, case.step_s, "tustin", "float64")
    slots = np.arange(n)
    ctrl.initialise(slots, _meas(plant, idx))
    queue = [tuple(np.array(ctrl.last[k], dtype=float) for k in REMOTE_REFERENCES)] * delay_samples
    m = case.plant_steps_per_sample
    rows, trip_t, out = [], math.nan, None
    for k in range(case.n_steps):
        _events(plant, k, case)
        if k % m == 0:
            meas = _meas(plant, idx)
            _, out, _ = ctrl.advance_slots(slots, np.array([getattr(meas, f) for f in MEAS_FIELDS], dtype=float))
            queue.append(tuple(out[CTRL_OUTPUTS.index(r)] for r in REMOTE_REFERENCES))
            plant.apply_remote(idx, *queue.pop(0))
        plant.step()
        trip_t = _record(plant, idx, k, case, rows, trip_t, out[CTRL_OUTPUTS.index("delta")],
                         out[CTRL_OUTPUTS.index("e_mag")])
        if not np.isfinite(rows[-1][0]):
            break
    return _with_trips(_stack(rows, case), plant, idx, trip_t)


def _record(plant, idx, k: int, case: FaultCase, rows: list, trip_t: float, delta, e_mag) -> float:
    """Step ``k``'s traces appended to ``rows``; the first trip time of the turbines ``idx`` so far [s]."""
    rec = plant.recorded()
    rows.append((rec["v_pcc"], rec["q"][idx], delta, e_mag))
    if math.isnan(trip_t) and plant.trips[idx].any():
        trip_t = (k + 1) * case.plant_step_s
    return trip_t


def _with_trips(res: dict, plant, idx, trip_t: float) -> dict:
    res["trips"] = plant.trips[idx].copy()
    res["trip_t"] = trip_t
    return res


def _law_positions(plant, idx) -> np.ndarray:
    """Where the hd_visc turbines ``idx`` are in the plant's law arrays (``plant.visc_idx``, ascending)."""
    pos = np.searchsorted(plant.visc_idx, idx)
    if not np.array_equal(plant.visc_idx[np.minimum(pos, len(plant.visc_idx) - 1)], idx):
        raise ValueError(f"turbines {idx} are not all hd_visc (hd_visc: {plant.visc_idx})")
    return pos


def _law_traces(plant, pos) -> tuple[np.ndarray, np.ndarray]:
    """(delta, e_mag) of the hd_visc law at ``pos``: the values of ``outputs()``' ``visc_delta`` and
    ``visc_e`` of those turbines, read from the plant's present evaluation (the one ``outputs()`` and
    ``recorded()`` read) without ``outputs()``' full node-voltage solve, fault sequences and losses."""
    lo = plant._eval_cached()[2]["law_out"]  # no public accessor of the law's outputs but outputs()
    if lo is None:
        return np.full(len(pos), np.nan), np.full(len(pos), np.nan)
    return lo.delta[pos], lo.e_mag[pos]


def _meas(plant, idx) -> SimpleNamespace:
    return SimpleNamespace(**{k: np.asarray(v)[idx] for k, v in plant.measurements().items()})


def _stack(rows, case: FaultCase) -> dict[str, np.ndarray]:
    """Traces (plant step x turbine); a run stopped early (non-finite values) is padded with NaN."""
    out = {name: np.array([r[j] for r in rows], dtype=float) for j, name in enumerate(QUANTITIES)}
    out["v_pcc"] = out["v_pcc"][:, None]
    finite = np.isfinite(out["delta"]).all(axis=1)
    n_ok = len(rows) if finite.all() else int(np.argmin(finite))
    out["delta"][:n_ok] = np.unwrap(out["delta"][:n_ok], axis=0)
    n = case.n_steps
    for name in QUANTITIES:
        if len(rows) < n:
            out[name] = np.vstack([out[name], np.full((n - len(rows), out[name].shape[1]), np.nan)])
    out["t"] = (np.arange(n) + 1) * case.plant_step_s
    return out


def compare(sdc: dict[str, np.ndarray], hd: dict[str, np.ndarray]) -> dict[str, dict[str, float]]:
    """Per quantity: worst (over turbines) RMS deviation and RMS / range of the HD trace [%]
    (inf where the SDC's trace is not finite)."""
    res = {}
    for name in QUANTITIES:
        diff = sdc[name] - hd[name]
        rms = np.where(np.isfinite(diff).all(axis=0), np.sqrt(np.mean(np.nan_to_num(diff) ** 2, axis=0)), np.inf)
        rel = rms / np.ptp(hd[name], axis=0)
        res[name] = {"rms": float(rms.max()), "rms_over_range_pct": float(100 * rel.max()),
                     "hd_range": float(np.ptp(hd[name], axis=0).min())}
    return res
