"""The report's NM row for F6 (report/exp_network_model.py) end to end: F6's fault on the quasi-static
and the dynamic-phasor network; the SC's first peak over its initial symmetrical current shows the DC
offset only on the dynamic network, and the SC's terminal voltage in the fault is the same on both."""

from __future__ import annotations

import numpy as np
import pytest

import plant.cases
from plant.dynamic_network import DYNAMIC_STEP_S
from report.catalogue import EXPERIMENTS
from report.dynamic_cases import dynamic, dynamic_network
from report.exp_network_model import NM, _nm_f6, osc_hz
from report.registry import CONSISTENCY, VERDICTS, Context


def test_nm_is_registered_offline_with_consistency_rows_only():
    assert NM in EXPERIMENTS and NM.kind == "offline"
    assert [c.id for c in NM.claims] == ["NM.F6", "NM.F7", "NM.F8", "NM.F9"]
    assert all(c.kind == CONSISTENCY and not c.beyond for c in NM.claims)


def test_dynamic_builds_the_case_on_the_dynamic_network_and_leaves_the_default_alone():
    p = dynamic(plant.cases.sc_plant, h_sc=3.0)
    assert p.params.network_model == "dynamic_phasor" and p.step_s == DYNAMIC_STEP_S and p.params.condenser.h == 3.0
    with dynamic_network():
        pass
    q = plant.cases.bare_plant()
    assert q.params.network_model == "quasi_static" and q.step_s != DYNAMIC_STEP_S


def test_osc_hz_finds_the_frequency_of_a_ringing_trace():
    t = np.arange(0.0, 1.0, 2e-3)
    assert abs(osc_hz(t, 1.0 + 0.01 * t + 0.1 * np.sin(2 * np.pi * 7.0 * t)) - 7.0) < 0.2


@pytest.mark.slow
def test_nm_f6_row_the_dc_offset_only_on_the_dynamic_network(tmp_path):
    """The row as the report makes it with --quick (the dynamic runs 0.3 s: ≈ 10–20 s here)."""
    found = _nm_f6(Context(out_dir=tmp_path, quick=True))
    assert found.verdict in VERDICTS and found.reason.strip()
    m = found.measured
    assert 1.5 < m["peak_over_i_initial"] < 2.1  # the phase current's first peak over I'': the offset
    kappa = m["quasi_static"]["kappa"]
    assert abs(m["positive_sequence_peak_ratio"] / kappa - 1.0) < 0.1  # the positive sequence alone: κ
    assert abs(m["rel_diff"]["b"]) < 0.05  # the SC's terminal V1 in the fault: the same on both networks
    assert (tmp_path / "nm_f6_network_models.png").exists()
