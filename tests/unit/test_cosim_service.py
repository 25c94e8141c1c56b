"""The offline co-simulation under a network run's conditions (plant.cosim_service), no network.

* Under the paper's set-up (P* = 0 from t = 0, the controller started at once) and with the
  measurement taken after a step's events, it is the same loop as plant.cosim.run_sdc: round trip
  L samples = run_sdc's delay L - 1 (measured: RMS / HD range below 0.03 %; bound 0.05 %).
* float32 values on the wire change nothing that matters (measured 3e-6 % of Q's range).
* The service's order (a MEAS leaves before the next step's events, so the SDC sees a fault one
  sample later) and one late answer at the fault onset are what trip the converters in a network
  run (|i| 2.23 p.u. > 2.0): the same conditions with every answer in time peak at 1.50 p.u.
"""

from __future__ import annotations

import numpy as np
import pytest

from plant.cosim import FaultCase, run_hd, run_sdc
from plant.cosim_service import ServiceConditions, compare_window, run_service_sdc

CASE = FaultCase(t_fault_s=0.3, t_clear_s=0.45, t_end_s=0.8)
STEPS = int(round(CASE.t_end_s / CASE.step_s))
FAULT = ((int(round(CASE.t_fault_s / CASE.step_s)), True), (int(round(CASE.t_clear_s / CASE.step_s)), False))
PAPER = ServiceConditions(start_steps=(0, 0, 0, 0), fault_steps=FAULT, n_steps=STEPS, p_star=0.0)


@pytest.fixture(scope="module")
def hd():
    return run_hd(CASE)


def _pct(a, b, ref, names=("v_pcc", "q", "delta", "e_mag")):
    res = compare_window(a, b, ref, 0.0, CASE.t_end_s)
    return {name: res[name]["rms_over_range_pct"] for name in names}


def test_one_sample_round_trip_is_run_sdc_without_delay(hd):
    service = run_service_sdc(PAPER, lag=1, quantise=False, meas_after_events=True)
    for name, pct in _pct(service, run_sdc(CASE, delay_samples=0), hd).items():
        assert pct < 0.06, (name, pct)  # measured 0.050 % (q) on the issue-28 turbines


def test_two_sample_round_trip_is_run_sdc_with_one_sample_delay(hd):
    service = run_service_sdc(PAPER, lag=2, quantise=False, meas_after_events=True)
    # δ and E are those of the CTRL applied (one sample older than run_sdc's record), so only the plant's
    for name, pct in _pct(service, run_sdc(CASE, delay_samples=1), hd, ("v_pcc", "q")).items():
        assert pct < 0.05, (name, pct)


def test_float32_on_the_wire_is_negligible(hd):
    exact = run_service_sdc(PAPER, lag=1, quantise=False)
    wire = run_service_sdc(PAPER, lag=1, quantise=True)
    assert not np.array_equal(exact["q"], wire["q"])  # the rounding is applied
    for name, pct in _pct(exact, wire, hd).items():
        assert pct < 1e-3, (name, pct)


def test_one_late_answer_at_the_fault_onset_is_held_by_the_converters_local_limit():
    # as fault_4visc_network.yaml runs: grid-following at MPPT, ViSC from 0.2 s, fault at 1.0 s
    cond = ServiceConditions(start_steps=(300, 300, 300, 300), fault_steps=((1493, True),), n_steps=1520)
    in_time = run_service_sdc(cond, lag=1)
    assert in_time["trips"].sum() == 0 and in_time["i_wt"].max() < 1.6
    lags = np.ones((cond.n_steps, 4), dtype=int)
    lags[1494] = 2  # the answer to the first faulted sample misses its step
    late = run_service_sdc(cond, lag=lags)
    # the pre-fault reference held two steps into the fault: without the converter's local limit the current
    # overshot the 1.5 p.u. limit and the 2.0 p.u. trip (2.09); with it (TurbineParams.i_max_local, issue 39
    # item 11) the converter draws at most 1.5 p.u. within 1 % (measured 1.489) and does not trip
    assert late["i_wt"].max() <= 1.5 * 1.01 and late["trips"].sum() == 0
    # before the late answer both runs are the same run
    np.testing.assert_array_equal(late["q"][:1494], in_time["q"][:1494])


def test_the_start_takes_the_turbines_from_rated_power_towards_zero():
    cond = ServiceConditions(start_steps=(300, 300, 300, 300), fault_steps=(), n_steps=1400)
    run = run_service_sdc(cond, lag=1)
    p = run["p_wt"]
    assert np.isnan(run["delta"][:300]).all() and np.isfinite(run["delta"][301:]).all()  # no CTRL before the start
    assert (np.abs(p[:300] - 1.0) < 0.02).all()  # grid-following at rated power (wind above rated)
    assert (np.abs(p[-1]) < 0.1).all()  # the ViSC's p_ref = 0 has taken it to (nearly) no power 0.74 s later
