"""Programmable H through the network (report F4hnet, issue 28 item 8), briefly: the scenario
scenarios/paper/f4_programmable_h.yaml with its timeline compressed to 1.6 s. The OWFCC's set_params
{h: 5} goes OWFCC -> SDN app -> SDC; the SDC's record says it put h = 5 in effect for each of the four
SDViSCs (not pending: they were already stepping), and they kept receiving control after it. Counts
and records only, nothing about this machine's speed."""

from __future__ import annotations

import json

import numpy as np
import pytest

from report import programmable_h as ph
from report.exp_programmable_h import sdc_record
from report.network_runs import read_timeseries, write_variant
from tests.integration.helpers import assert_no_leftovers, run_scenario

pytestmark = pytest.mark.network

T_ON, T_LOAD, T_SET, DURATION = 0.2, 0.5, 0.8, 1.6  # visc_on, first load step, set_params; the second step at 1.0 s


def _brief(timeline: list[dict]) -> list[dict]:
    times = {"visc_on": T_ON, "set_params": T_SET}
    loads = iter((T_LOAD, 1.0))
    out = []
    for e in timeline:
        t = next(loads) if e["do"] == "load_step" else times.get(e["do"], e["t"])
        out.append({**e, "t": t})
    return out


def test_the_sdc_applies_the_owfcc_request_for_h_5_at_run_time(tmp_path):
    path = write_variant(tmp_path / "scenarios", ph.NAME, "programmable_h_brief",
                         {"timeline": _brief, "duration_s": DURATION})
    out = tmp_path / "run"
    summary = run_scenario(path, out, "--time-scale", "8")  # the full farm model: headroom, not a timing test
    turbines = ph.case()["turbines"]
    asked = [e for e in summary["events"] if e.get("type") == "owfcc_request" and e.get("cmd") == "set_params"]
    assert sorted(e["wt"] for e in asked) == sorted(turbines) and all(e["params"] == {"h": 5.0} for e in asked)
    applied = sdc_record(out)
    assert sorted(e["wt"] for e in applied) == sorted(turbines), applied  # one record per request, one SDC
    for e in applied:
        assert e["status"] == "OK" and e["params"] == {"h": 5.0} and e["in_effect"]["h"] == 5.0, e
        t = e["t_wall"] - summary["t0_wall"]  # the SDC's records are on the run's clock
        assert e["pending"] is False and T_SET <= t < T_SET + 0.1, e  # stepping already; on the request
    stats = json.loads((out / "sdc1_stats.json").read_text())
    starts = [e for e in stats["events"] if e.get("cmd") == "START_INSTANCE" and e["status"] == "OK"]
    assert sorted(e["wt"] for e in starts) == sorted(turbines)
    ts = read_timeseries(out / "timeseries.csv")
    after = ts["t"] > T_SET + 0.1
    for wt in turbines:  # control went on after the change: CTRL packets received after it
        assert np.diff(ts[f"{wt}.ctrl_rx"][after]).sum() > 0, wt
    assert_no_leftovers()
