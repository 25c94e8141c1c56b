"""The offline co-simulation under a network run's conditions (plant.cosim_service), no network.

* Under the paper's set-up (P* = 0 from t = 0, the controller started at once) and with the
  measurement taken after a step's events, it is the same loop as plant.cosim.run_sdc: round trip
  L samples = run_sdc's delay L - 1 (RMS / HD range; the numbers at each test). The service's SDC
  starts one sample later (its first MEAS is the state after step 0, run_sdc steps on the state at
  0), so the two trajectories differ by that one sample of the start transient.
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


E_STEP = 1e-3  # p.u. in one sample: a step of the SDC's E (one unheld AVR sample, ~2.3e-3 p.u.)


def _e_steps(e: np.ndarray) -> list[np.ndarray]:
    """Per turbine, the rows in the fault where the SDC's E steps by more than E_STEP in a sample."""
    t = CASE.plant_step_s * (np.arange(len(e)) + 1)
    fault = (t > CASE.t_fault_s) & (t < CASE.t_clear_s)
    jump = np.zeros(e.shape, dtype=bool)
    jump[1:] = np.abs(np.diff(e, axis=0)) > E_STEP
    return [np.nonzero(jump[:, j] & fault)[0] for j in range(e.shape[1])]


def test_one_sample_round_trip_is_run_sdc_without_delay(hd):
    service = run_service_sdc(PAPER, lag=1, quantise=False, meas_after_events=True)
    sdc = run_sdc(CASE, delay_samples=0)
    for name, pct in _pct(service, sdc, hd, ("v_pcc", "q", "delta")).items():
        # measured (IEC WPP, 2026-12-05) 0.0011 / 0.0169 / 0.0045 %; a one-sample delay would be 0.13 / 3.3 / 0.76 %
        assert pct < 0.06, (name, pct)
    # E: while current-limited in the fault the SDC's E rises in steps of ~2.3e-3 p.u. (the AVR is held while
    # limited, the limiter evaluated with the AVR held; a sample where that finds the current just inside i_max
    # is one unheld AVR sample). Which sample a crossing of the limit falls on depends on the 1e-5-level
    # difference the one-sample start leaves: measured 14 steps in both runs (23 rows with the fault's first 9
    # samples, where E rises fast), 3 of them one sample apart (run_sdc's rows 598/613/636, the service's
    # 599/614/637), each a 2.3e-3 p.u. difference for one sample, which alone took E's RMS / HD range from
    # 0.073 % to 0.116 % (the farm's WPP orders, 0.014-0.017 p.u., set the operating point;
    # with the WPP's k_i = 0, its start order held, the same 0.121 %; with no WPP 0.051 % and no step apart;
    # a one-sample delay would be 1.35 %). The same steps, at most one sample apart:
    steps_service, steps_sdc = _e_steps(service["e_mag"]), _e_steps(sdc["e_mag"])
    for a, b in zip(steps_service, steps_sdc):
        assert len(a) == len(b) >= 10 and np.abs(a - b).max() <= 1, (a, b)
    apart = np.abs(service["e_mag"] - sdc["e_mag"]) > E_STEP
    assert apart.sum(axis=0).max() <= 3, np.nonzero(apart)
    for j, (a, b) in enumerate(zip(steps_service, steps_sdc)):
        assert set(np.nonzero(apart[:, j])[0]) <= set(np.minimum(a, b)), j  # only where a step fell one sample apart
    # the rest: E's start transient one sample apart, larger from the WPP's start order (t < 0.3 s gives
    # 0.071 % of the 0.073 %; 0.049 % with no WPP); measured 0.073 %
    e_rest = np.where(apart, np.nan, service["e_mag"])
    assert _pct({**service, "e_mag": e_rest}, sdc, hd, ("e_mag",))["e_mag"] < 0.08


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
