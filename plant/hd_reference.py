"""The HD reference: the hardware-dependent ViSC the paper's SDC is judged against, defined once (and
the HD reference of any law of sdc_unit.laws: :func:`run_law_reference`).

In the paper (Section IV-B) the HD ViSC is "directly implemented in RSCAD": the continuous ViSC law
runs inside the real-time simulator at the simulator's time step, tens of µs, and its inner current
loop is the converter's own. Here that is:

* the continuous law in the plant (mode ``hd_visc``, equations in :mod:`sdc_unit.law_kernels`);
* the SDC's own law parameters, its current loop included (``sdc_unit.params.ViscParams``: k_pc 0.13,
  k_ic 1.53): the paper's HD ViSC is the same controller implemented in RSCAD, so the comparison
  measures the implementation (sampling, Tustin, the network), not a retuned loop [paper, Section IV-B:
  "the hardware-dependent ViSC ... directly implemented in RSCAD"]. Before issue 39 item 8 the reference
  ran the plant converter's own loop (``TurbineParams`` ``kpc`` 1.27, ``kic`` 14.3, D'Arco's ≈ 5000 rad/s,
  which cannot be sampled at Ts = 0.67 ms): F1 then measured mostly the retuned loop (worst 1.08 % of
  which 1.00 % was that loop). It stays as :func:`converter_loop_visc_params`, for the split of that gap;
* a plant step of :data:`HD_STEP_S` = 50 µs [src: RTDS: 50 µs typical] (a simulator's step is tens of
  µs; halving it to 25 µs changes a small fault case's traces by ≤ 0.2 % of their range (0.11 % measured),
  ``tests/unit/test_hd_reference.py``).

Comparison with a run of the SDC (``plant.cosim.run_sdc``, the plant at Ts / m): both traces are taken
at the SDC's sample instants t_j = j·Ts (:func:`on_samples`; the reference linearly interpolated
between its 50 µs rows, the SDC's run read at its own rows), so every sample weighs the same whatever
the plant steps. The reference's fault and clearance are applied at the first 50 µs step at or after
the instant the SDC run's plant applies them (:func:`reference_case`: on the 0.67 ms grid the fault of
1.0 s falls at 1.00031 s, the reference's at 1.00035 s); with the fault at exactly 1.0 s in the
reference, the one sample at 1.00031 s, before the fault in the SDC's run and after it in the
reference, alone would give |V_pcc| a deviation of ≈ 1.7 % of its range: the rounding of the event time
onto the SDC run's grid, not the controller.
"""

from __future__ import annotations

import math
from dataclasses import replace
from functools import lru_cache

import numpy as np

from plant.cosim import QUANTITIES, FaultCase, run_hd, run_law
from plant.params import TurbineParams
from sdc_unit.params import ViscParams

HD_STEP_S = 50e-6
"""Plant step of the HD reference [s] [src: RTDS: 50 µs typical; the paper's RSCAD model runs at the
simulator's step]."""

LABEL = "HD ViSC (continuous law, the SDC's parameters, 50 µs)"
"""How figures and texts name the reference."""


def simulator_steps_per_sample(ts_s: float) -> int:
    """Plant steps per SDC sample that put the plant of an SDC run at about HD_STEP_S (0.67 ms → 13, a
    51.5 µs step): the SDC sampled every Ts while the plant runs at a simulator's step, as the paper's
    SDC drove RTDS (``FaultCase.plant_steps_per_sample``)."""
    return max(1, round(ts_s / HD_STEP_S))


def reference_visc_params(base: ViscParams | None = None) -> ViscParams:
    """The HD reference's law parameters: ``base`` (default ``ViscParams()``), the SDC's own, unchanged
    (the same controller implemented in the simulator) [paper, Section IV-B]."""
    return base or ViscParams()


def converter_loop_visc_params(base: ViscParams | None = None) -> ViscParams:
    """``base`` with the plant converter's own current loop (TurbineParams ``kpc``, ``kic`` [src: D'Arco,
    Suul, Fosso EPSR 2015]): the pre-issue-39 reference, kept for splitting F1's gap into the loop's and
    the sampling's part; not the paper's HD ViSC."""
    turbine = TurbineParams()
    return (base or ViscParams()).with_changes(k_pc=turbine.kpc, k_ic=turbine.kic)


def realised_instant(t_s: float, step_s: float) -> float:
    """The instant a plant stepping ``step_s`` applies an event asked for at ``t_s`` (the nearest step,
    as ``plant.cosim``)."""
    return round(t_s / step_s) * step_s


def reference_case(case: FaultCase) -> FaultCase:
    """The HD reference's case for comparison with a run of ``case``: the same farm and ViSC turbines, an
    end at or after the run's last row (3 s at 0.67 ms: 3.0003 s), the plant at HD_STEP_S, fault and clearance at the first HD step at or after the instants
    ``case``'s plant applies them."""
    def on_hd_grid(t_s: float) -> float:
        return math.ceil(realised_instant(t_s, case.plant_step_s) / HD_STEP_S - 1e-6) * HD_STEP_S

    last = math.ceil(case.n_steps * case.plant_step_s / HD_STEP_S - 1e-6) * HD_STEP_S  # covers the run's last row
    return replace(case, step_s=HD_STEP_S, plant_steps_per_sample=1, t_fault_s=on_hd_grid(case.t_fault_s),
                   t_clear_s=on_hd_grid(case.t_clear_s), t_end_s=last)


@lru_cache(maxsize=4)
def _run_reference_case(ref_case: FaultCase) -> dict[str, np.ndarray]:
    return run_hd(ref_case, reference_visc_params())


def run_reference(case: FaultCase) -> dict[str, np.ndarray]:
    """The HD reference's traces (rows every HD_STEP_S) for comparison with a run of ``case``
    (cached: several experiments in one process share it; do not modify the arrays)."""
    return _run_reference_case(reference_case(case))


LAW_LABEL = "HD reference of the law (sampled every 50 µs, zero delay)"
"""How figures and texts name the HD reference of a law of sdc_unit.laws (:func:`run_law_reference`)."""


@lru_cache(maxsize=4)
def _run_law_reference_case(ref_case: FaultCase, law: str) -> dict[str, np.ndarray]:
    return run_law(ref_case, law)


def run_law_reference(case: FaultCase, law: str) -> dict[str, np.ndarray]:
    """The HD reference of any law of :data:`sdc_unit.laws.LAWS` for a run of ``case``: the law, as the
    SDC runs it, sampled every HD_STEP_S with the plant at HD_STEP_S and no transport delay
    (:func:`plant.cosim.run_law` on :func:`reference_case`). A law needs no form inside the plant to
    have one: for the ViSC it agrees with the plant-integrated hd_visc reference to 0.05 % of each
    trace's range (tests/unit/test_law_hd_reference.py). Cached; do not modify the arrays."""
    return _run_law_reference_case(reference_case(case), law)


def sample_instants(case: FaultCase) -> np.ndarray:
    """The SDC's sample instants j·Ts, j = 1 … over the run [s]."""
    n = int(round(case.t_end_s / case.step_s))
    return (np.arange(n) + 1) * case.step_s


def on_samples(traces: dict[str, np.ndarray], case: FaultCase) -> dict[str, np.ndarray]:
    """``traces`` (``plant.cosim`` layout: rows after each plant step) taken at ``case``'s sample
    instants, linearly interpolated between rows (exact on the SDC run's own rows); ``trips`` and
    ``trip_t`` copied."""
    t = sample_instants(case)
    t = t[t <= traces["t"][-1] + 1e-9]
    out = {name: np.column_stack([np.interp(t, traces["t"], col) for col in np.asarray(traces[name]).T])
           for name in QUANTITIES}
    out["t"] = t
    out.update({k: traces[k] for k in ("trips", "trip_t") if k in traces})
    return out


def reference_on_samples(case: FaultCase) -> dict[str, np.ndarray]:
    """The HD reference for a run of ``case``, taken at its sample instants."""
    return on_samples(run_reference(case), case)
