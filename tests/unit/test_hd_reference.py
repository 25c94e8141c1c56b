"""The HD reference (plant/hd_reference.py): its definition, its step, and F1's number against it.

Offline. The 50 µs against 25 µs test runs a 6-turbine farm over 0.35 s; the F1 test runs F1.a itself
(the full farm, 2 s: the 50 µs reference ≈ 5 s, the SDC on its 51.5 µs plant ≈ 3.5 s on this machine).
The pinned F1 numbers were measured on the plant of b23ef55 (docs/report.md, F1): a change of the plant's
fault behaviour (e.g. grid-following turbines injecting reactive current during the fault) moves them
and should update them here and there.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from plant import hd_reference as hd
from plant.cosim import FaultCase, compare, run_hd, run_sdc
from plant.params import TurbineParams
from sdc_unit.params import ViscParams

SMALL = FaultCase(visc_turbines=(0, 3), n_turbines=6, t_fault_s=0.1, t_clear_s=0.2, t_end_s=0.35)


def _worst(cmp: dict) -> float:
    return max(c["rms_over_range_pct"] for c in cmp.values())


def test_the_reference_is_the_sdcs_own_law_at_50_us():
    """Issue 39 item 8: the paper's HD ViSC is the same controller in RSCAD: the SDC's parameters, its
    current loop (k_pc 0.13, k_ic 1.53) included; the converter's own loop (1.27 / 14.3) only as the
    named pre-issue-39 variant."""
    assert hd.reference_visc_params() == ViscParams()
    conv = hd.converter_loop_visc_params()
    assert (conv.k_pc, conv.k_ic) == (TurbineParams().kpc, TurbineParams().kic) == (1.27, 14.3)
    assert replace(conv, k_pc=ViscParams().k_pc, k_ic=ViscParams().k_ic) == ViscParams()
    assert hd.HD_STEP_S == 50e-6


def test_the_reference_applies_the_events_where_the_sdc_runs_plant_does():
    ref = hd.reference_case(FaultCase())  # 0.67 ms grid: fault at 1.00031 s, clearance at 1.2998 s
    assert ref.plant_step_s == 50e-6 and ref.n_steps == 39999  # to the run's last row, 1.99995 s
    assert ref.t_fault_s == pytest.approx(1.00035) and ref.t_clear_s == pytest.approx(1.2998)
    long = FaultCase(t_end_s=3.0)  # its last sample 4478 × 0.67 ms = 3.00026 s: the reference covers it
    assert hd.reference_case(long).t_end_s == pytest.approx(3.0003)
    assert len(hd.on_samples(run_sdc(replace(SMALL, t_end_s=3.0e-3)), SMALL)["t"]) == 4
    ref = hd.reference_case(FaultCase(step_s=0.25e-3))  # on both grids
    assert (ref.t_fault_s, ref.t_clear_s) == (pytest.approx(1.0), pytest.approx(1.3))


def test_on_samples_reads_the_sdc_run_at_its_own_rows():
    case = replace(SMALL, t_end_s=0.02, plant_steps_per_sample=3)
    r = run_sdc(case)
    s = hd.on_samples(r, case)
    assert len(s["t"]) == 30 and s["t"][0] == pytest.approx(0.67e-3)  # 90 plant steps of 0.223 ms
    np.testing.assert_allclose(s["q"], r["q"][2::3], rtol=0, atol=1e-12)
    assert "trips" in s


@pytest.mark.slow
def test_halving_the_reference_step_changes_it_by_less_than_a_fifth_of_a_percent():
    ref_case = hd.reference_case(SMALL)
    at_50 = run_hd(ref_case, hd.reference_visc_params())
    at_25 = run_hd(replace(ref_case, step_s=25e-6), hd.reference_visc_params())
    assert at_50["q"].shape == (6995, 2) and at_25["q"].shape == (13990, 2)
    assert np.ptp(at_50["q"]) > 0.5  # a real disturbance
    change = compare(hd.on_samples(at_50, SMALL), hd.on_samples(at_25, SMALL))
    # measured 0.110 % (e_mag) with the SDC's own law as the reference on c1ecc6b's IEC WPP (0.091 % with the
    # converter's loop; 0.037 % before that WPP): a step's error far below F1's deviations
    assert _worst(change) < 0.2, change


@pytest.mark.slow
def test_f1_tustin_at_067ms_against_the_50us_reference():
    # F1.a of ./testbed report: the SDC at 0.67 ms on a plant at 0.67 ms / 13, no added delay
    case = FaultCase(plant_steps_per_sample=hd.simulator_steps_per_sample(0.67e-3))
    assert case.plant_steps_per_sample == 13
    res = compare(hd.on_samples(run_sdc(case), case), hd.reference_on_samples(case))
    pct = {q: c["rms_over_range_pct"] for q, c in res.items()}
    assert pct == pytest.approx(F1_PCT, abs=0.05), pct  # the tolerance: rounding across machines and numba builds
    # the largest: e_mag, 74 % of its squared deviation 1.5-2 s, after the event (the same 3.45 % against the
    # pre-issue-39 reference: not the current loop); q's fell from 2.19 % to 1.52 % with the SDC's own loop
    assert max(pct, key=pct.get) == "e_mag"


F1_PCT = {"v_pcc": 0.264, "q": 1.586, "delta": 0.392, "e_mag": 3.384}  # measured with the SDC's own law as the reference (issue 39 item 8), the converter's active damping under remote/hd_visc references in both network models (item 10), on c1ecc6b's IEC 61400-27-1 WPP
