"""The paper's validation case on the full 50-turbine plant, offline: the Tustin SDViSC at
Ts = 0.67 ms against the hardware-dependent ViSC, single-phase-to-ground fault 1.0–1.3 s.

Measured (docs/sdc.md): RMS / range of the HD trace, worst of the four ViSC turbines,
no transport delay: |V_pcc| 0.02 %, Q 0.32 %, delta 0.16 %, E 0.34 %; one sample of delay:
0.11 %, 2.3 %, 0.87 %, 0.92 %. The bounds below are the issue's 1 % where it is met, else the
measured value with a margin.
"""

from __future__ import annotations

import pytest

from plant.cosim import FaultCase, compare, run_hd, run_sdc

CASE = FaultCase()


@pytest.fixture(scope="module")
def hd():
    return run_hd(CASE)


def test_hd_case_is_a_real_disturbance(hd):
    # the fault moves the PCC voltage and the ViSCs' Q and delta by amounts worth comparing
    assert hd["v_pcc"].min() < 0.8 and hd["v_pcc"][-1, 0] > 0.95
    assert compare(hd, hd)["q"]["hd_range"] > 0.5 and compare(hd, hd)["delta"]["hd_range"] > 0.05


def test_tustin_at_067ms_follows_hd_within_1_percent(hd):
    res = compare(run_sdc(CASE, delay_samples=0), hd)
    for name in ("v_pcc", "q", "delta", "e_mag"):
        assert res[name]["rms_over_range_pct"] < 1.0, (name, res[name])


def test_one_sample_of_transport_delay_costs_q_accuracy_but_keeps_the_rest(hd):
    res = compare(run_sdc(CASE, delay_samples=1), hd)
    for name in ("v_pcc", "delta", "e_mag"):
        assert res[name]["rms_over_range_pct"] < 1.0, (name, res[name])
    assert res["q"]["rms_over_range_pct"] < 3.0
