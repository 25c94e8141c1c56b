"""F1 on the EMT backend (report/exp_emt_f1.py): the SDC at Ts against the HD ViSC, and the mechanism its
docs state (docs/plant.md, "F1"): the deviation under the SLG fault comes from the fault's negative
sequence, so a balanced fault of about the same depth gives a clearly smaller one.

Tolerances: before the fault both runs at the same operating point within 1e-3 p.u. (V_pcc, E); the worst
quantity's deviation with the balanced fault at most half the SLG fault's (measured 17.4 % vs 2.1 %); with the
law's current and P, Q measured as their positive sequence (frame's delayed-signal cancellation, ``dsc_ipq``) the
worst deviation at most half the raw Park phasors' (measured 5.4 % vs 17.4 %); the positive-sequence measurements
follow the raw ones without a fault (terminal |v| within 1e-3 p.u. of the raw run's over 0.3 s after
activation, both exchanges), the terminal voltage's own positive sequence (``dsc``) with the law every step does
not (> 0.05 p.u. by 0.3 s; measured: diverging from 0.05 s, 1e19 by 0.3 s)."""

from __future__ import annotations

import numpy as np
import pytest


@pytest.mark.slow
def test_sdc_vs_hd_on_emt_deviates_by_the_faults_negative_sequence():
    from report.exp_emt_f1 import FAULT, R_BALANCED, emt_pct  # noqa: PLC0415

    slg, hd, sdc, n = emt_pct()
    before = hd["t"][:n] < FAULT[0]
    for q in ("v_pcc", "e_mag"):
        assert np.max(np.abs(sdc[q][:n][before] - hd[q][:n][before])) < 1e-3
    balanced = emt_pct(fault_kind="3ph", r_fault=R_BALANCED)[0]
    assert max(balanced.values()) <= 0.5 * max(slg.values())
    assert slg["v_pcc"] < 2.0  # the PCC's positive sequence itself is alike (F1's rule: partly or better)


def _terminals(meas: str, exchange: str) -> np.ndarray:
    """|v| of the four SDViSCs' terminals over 0.3 s after their activation at 0 (no fault: balanced)."""
    from plant.emt.farm import EmtFarm  # noqa: PLC0415

    m = EmtFarm(4, None, farm_model="gfl", exchange=exchange, meas=meas)
    return np.abs(m.run(0.3, events=[(0.0, EmtFarm.activate)])["v_t"])


@pytest.mark.slow
def test_positive_sequence_measurements_follow_the_raw_ones_when_balanced_but_the_voltages_feed_forward_does_not():
    for exchange in ("step", "ts"):
        raw = _terminals("park", exchange)
        for meas in ("dsc_pq", "dsc_ipq"):
            assert np.max(np.abs(_terminals(meas, exchange) - raw)) < 1e-3, (meas, exchange)
    v, raw = _terminals("dsc", "step"), _terminals("park", "step")
    assert not np.all(np.isfinite(v)) or np.max(np.abs(v - raw)) > 0.05


@pytest.mark.slow
def test_positive_sequence_current_and_power_halve_the_deviation():
    from report.exp_emt_f1 import emt_pct  # noqa: PLC0415

    raw = max(emt_pct("park")[0].values())
    pos = max(emt_pct("dsc_ipq")[0].values())
    assert pos <= 0.5 * raw
