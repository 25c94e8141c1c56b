"""The onshore aggregated SDViSC through the real network (issue 28 item 1, the cyber half):
scenarios/paper/f3_voltage_step.yaml, the paper's comparison arrangement — one 40 MVA SDViSC at the
onshore PCC (plant converter 50), its GTNET endpoint host wt6_1 on the substation switch sub1. The
OWFCC's visc_on makes the SDN app build the path sdc1–sub1–wt6_1 and start one SDC instance; MEAS,
CTRL and AKs flow only from then on; the PCC voltage's response to V* 1.00 → 1.04 is the offline
comparison run's (plant.cases.comparison_visc_plant) within F3net's tolerance. Counts and simulated
time only, nothing about this machine's speed (k = 8: headroom for the full farm model)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from report.exp_grid_net import AGREE_YES, f3_offline
from report.network_runs import read_timeseries, scenario_path
from tests.integration.helpers import assert_no_leftovers, run_scenario

pytestmark = pytest.mark.network

NAME, WT, T_ON, T_STEP = "f3_voltage_step", "wt6_1", 0.2, 1.0


def test_the_onshore_unit_is_controlled_as_a_visc_through_the_network(tmp_path):
    out = tmp_path / "run"
    summary = run_scenario(scenario_path(NAME), out, "--time-scale", "8")
    assert summary["topology"].get("onshore_units") == 1
    # the SDN app: the request for wt6_1 answered with a path from the primary SDC through sub1
    sdn = [json.loads(line) for line in (out / "sdn_events.jsonl").read_text().splitlines() if line.strip()]
    on = [e for e in sdn if e["type"] == "visc_on" and e["wt"] == WT]
    assert len(on) == 1 and on[0]["path"] == ["sdc1", "sub1", WT] and on[0]["sdc"] == "sdc1", on
    assert any(e["type"] == "sdc_reply" and e["wt"] == WT and e["cmd"] == "START_INSTANCE" and e["status"] == "OK"
               for e in sdn)
    assert summary["tables"]["T1"][WT]["switch"] == "sub1"
    assert summary["tables"]["T2"][WT] == "1/1" and summary["tables"]["T3"][WT] == "1/1"  # ViSC; path with AKs
    # one SDC instance for it, and its packets both ways; its AKs reached the SDN app (the only streaming turbine)
    stats = json.loads((out / "sdc1_stats.json").read_text())
    assert [e["wt"] for e in stats["events"] if e.get("cmd") == "START_INSTANCE" and e["status"] == "OK"] == [WT]
    wt = summary["turbines"][WT]
    packets = wt["packets"]
    assert min(packets["meas_tx"], packets["meas_rx_sdc"], packets["ctrl_tx_sdc"], packets["ctrl_rx"],
               packets["ak_tx"]) > 0, packets
    assert wt["per_sdc"]["sdc1"]["meas_rx"] > 0 and wt["ak_ones"] > 0
    counters = summary["sdn_counters"]
    assert counters["ak_rx"] > 0 and counters["paths_acknowledged"] >= 1, counters
    assert set(summary["turbines"]) == {WT}  # no other endpoint streamed
    assert wt["first_meas_tx_t"] >= T_ON  # nothing before the request
    assert not summary["converter_trips"] and not summary["fallbacks"]
    # the plant ran it remotely (mode 2) from the request on, and the PCC moved as offline
    ts = read_timeseries(out / "timeseries.csv")
    t, v = ts["t"], ts["v_pcc"]
    assert np.all(ts[f"{WT}.mode"][t > T_ON + 0.05] == 2)
    assert np.diff(ts[f"{WT}.ctrl_rx"][t > T_STEP]).sum() > 0
    off = f3_offline(NAME, float(t[-1]))
    rise_net = float(v[-1] - v[t < T_STEP][-1])
    rise_off = float(off["v_pcc"][-1] - off["v_pcc"][off["t"] < T_STEP][-1])
    assert rise_off > 0 and abs(rise_net - rise_off) <= AGREE_YES * abs(rise_off), (rise_net, rise_off)
    q_off = float(off["q_wt"][-1, 50])
    assert abs(float(ts[f"{WT}.q"][-1]) - q_off) <= AGREE_YES * abs(q_off), (ts[f"{WT}.q"][-1], q_off)
    assert_no_leftovers()
