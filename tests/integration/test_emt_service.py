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


F8 = ROOT / "scenarios" / "paper" / "f8_parallel_droop.yaml"
F8_VISC = ("wt3_1", "wt3_2", "wt3_3", "wt3_4")
F8_ON_S, F8_END_S = 1.0, 3.0  # the scenario's timeline
F8_Q_TOL = 0.002  # p.u.: each SDViSC's Q at the end vs the offline EmtFarm's (measured 1e-5 at k = 8, 2026-12-06)


def test_f8_on_the_emt_farm_closes_four_sdc_loops_through_the_switches(tmp_path):
    """F8's four parallel SDViSCs (cluster 3, droops 0.03 … 0.10) on the EMT farm arrangement
    (plant.emt.farm_service): every turbine's CTRLs reach the plant and are applied to the end, and the
    droops' Q is the offline EmtFarm's with the SDC's law in-process."""
    from plant.emt.farm import EmtFarm

    summary = run_scenario(F8, tmp_path, "--plant", "emt", "--time-scale", "auto", timeout=600)
    assert summary["completed"]
    assert sorted(summary["turbines"]) == list(F8_VISC)
    streamed = (F8_END_S - F8_ON_S) / summary["step_s"]
    for name in F8_VISC:
        p = summary["turbines"][name]["packets"]
        assert p["meas_tx"] == pytest.approx(streamed, rel=0.02), (name, p)
        assert p["ctrl_rx"] >= 0.98 * p["meas_tx"], (name, p)
    stats = json.loads((tmp_path / "plant_stats.json").read_text())
    assert stats["fallbacks"] == {}
    rows = list(csv.DictReader((tmp_path / "timeseries.csv").open()))
    t = np.array([float(r["t"]) for r in rows])
    q_end = np.array([float(rows[-1][f"{n}.q"]) for n in F8_VISC])
    for name in F8_VISC:
        assert np.all(np.array([int(r[f"{name}.mode"]) for r in rows])[t > F8_ON_S + 0.05] == T.REMOTE)
    off = EmtFarm(4, (0.03, 0.05, 0.07, 0.10), farm_model="gfl", exchange="ts")
    q_off = off.run(F8_END_S, events=[(F8_ON_S, off.activate)])["q"][-1]
    assert np.all(np.abs(q_end - q_off) < F8_Q_TOL), (q_end, q_off)
    assert np.all(np.diff(q_end) > 0)  # the smallest droop absorbs the most Q
    assert_no_leftovers()
