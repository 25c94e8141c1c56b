"""The paper's F6 (SLG fault at the PCC with the onshore 40 MVA SDViSC) on the EMT plant (``--plant emt``,
DPsim) through real Mininet + Open vSwitch + os-ken at the time scale calibrated before t = 0: the SDC's
CTRL closes the loop through the switches and drives the EMT converter through the fault."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from plant import turbine as T
from tests.integration.helpers import ROOT, assert_no_leftovers, run_scenario

pytestmark = pytest.mark.network

F6 = ROOT / "scenarios" / "paper" / "f6_slg_fault_current.yaml"
VISC_ON_S, FAULT_S, CLEAR_S, END_S = 0.2, 1.0, 1.2, 2.0  # the scenario's timeline


def test_f6_on_the_emt_plant_closes_the_sdc_loop_through_the_switches(tmp_path):
    summary = run_scenario(F6, tmp_path, "--plant", "emt", "--time-scale", "auto", timeout=600)
    assert summary["completed"]
    assert json.loads((tmp_path / "plant_config.json").read_text())["model"] == "emt"
    assert list(summary["turbines"]) == ["wt6_1"]
    ts = summary["step_s"]
    p = summary["turbines"]["wt6_1"]["packets"]
    streamed = (END_S - VISC_ON_S) / ts
    assert p["meas_tx"] == pytest.approx(streamed, rel=0.02), p
    assert p["meas_rx_sdc"] >= 0.98 * p["meas_tx"] and p["ctrl_tx_sdc"] >= 0.98 * p["meas_rx_sdc"], p
    assert p["ctrl_rx"] >= 0.98 * p["ctrl_tx_sdc"], p  # the CTRLs reached the EMT plant ...
    stats = json.loads((tmp_path / "plant_stats.json").read_text())
    assert p["ak_tx"] >= (END_S - VISC_ON_S) / 0.01 * 0.95, p  # ... which reported AKs every 10 ms
    rows = list(csv.DictReader((tmp_path / "timeseries.csv").open()))
    t = np.array([float(r["t"]) for r in rows])
    v = np.array([float(r["v_pcc"]) for r in rows])
    mode = np.array([int(r["wt6_1.mode"]) for r in rows])
    # ... and applied them: the unit stayed in remote mode from its first CTRL to the end (no fall-back
    # to its own law after 0.1 s without one), through the fault and its clearance
    assert np.all(mode[t > VISC_ON_S + 0.05] == T.REMOTE) and stats["fallbacks"] == {}
    assert stats["turbines"]["wt6_1"]["ak_ones"] >= 0.95 * p["ak_tx"]
    before = v[(t > FAULT_S - 0.1) & (t < FAULT_S)]
    assert np.all(np.isfinite(v)) and np.ptp(before) < 0.01
    assert np.min(v[(t > FAULT_S) & (t < CLEAR_S)]) < 0.8 * before.mean()  # the SLG fault at the PCC
    assert v[-1] == pytest.approx(before.mean(), rel=0.01)  # back after its clearance
    assert_no_leftovers()
