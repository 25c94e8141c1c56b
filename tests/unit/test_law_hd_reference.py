"""Every law of sdc_unit.laws gets an HD reference (plant.hd_reference.run_law_reference: the law
sampled at 50 µs through the plant's remote mode) and runs offline through the farm
(plant.cosim.run_law); for the ViSC both agree with what was there before."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from plant.cosim import QUANTITIES, FaultCase, compare, run_law, run_sdc
from plant.hd_reference import on_samples, reference_case, run_law_reference, run_reference

CASE = FaultCase(t_fault_s=0.6, t_clear_s=0.9, t_end_s=1.2)


def test_the_visc_through_the_generic_runner_is_run_sdc_bit_for_bit():
    """ViSC outputs unchanged: run_law(…, "visc") steps the same DiscreteVisc as run_sdc."""
    a, b = run_law(CASE, "visc", delay_samples=1), run_sdc(CASE, delay_samples=1)
    for name in (*QUANTITIES, "trips"):
        assert np.array_equal(a[name], b[name], equal_nan=True), name


def test_a_law_sampled_at_50us_is_the_hd_reference_for_the_visc():
    """The any-law HD reference, for the ViSC, against the plant-integrated hd_visc reference: within
    0.2 % of each trace's range (0.05 % measured on the 2 s case), while the SDC at 0.67 ms lies
    further from it (the comparison can tell a reference from a sampled run)."""
    case = replace(CASE, plant_steps_per_sample=13)
    ref = on_samples(run_reference(case), case)
    law_ref = on_samples(run_law_reference(case, "visc"), case)
    sdc = on_samples(run_law(case, "visc"), case)
    ref_gap = max(v["rms_over_range_pct"] for v in compare(law_ref, ref).values())
    sdc_gap = max(v["rms_over_range_pct"] for v in compare(sdc, ref).values())
    assert ref_gap < 0.2
    assert sdc_gap > 5 * ref_gap


def test_the_droop_law_rides_through_the_fault_beside_its_reference():
    """The droop law closing the farm's loop at 0.67 ms: no converter trips, back to its pre-fault
    voltage, and its traces follow its own HD reference (worst RMS within 5 % of the range)."""
    ref_case = reference_case(CASE)
    assert ref_case.plant_step_s == 50e-6
    run = run_law(CASE, "droop")
    ref = run_law_reference(CASE, "droop")
    assert not run["trips"].any() and not ref["trips"].any()
    v = run["v_pcc"][:, 0]
    t = run["t"]
    assert abs(v[-1] - v[t < CASE.t_fault_s][-1]) < 0.02
    assert v[(t > CASE.t_fault_s + 0.01) & (t < CASE.t_clear_s)].mean() < v[t < CASE.t_fault_s][-1] - 0.05  # the fault
    gap = compare(on_samples(run, CASE), on_samples(ref, CASE))
    assert max(g["rms_over_range_pct"] for g in gap.values()) < 5.0
