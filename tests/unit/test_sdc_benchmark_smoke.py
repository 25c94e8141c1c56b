"""Smoke test of benchmarks/sdc_throughput.py: the core function runs and returns the documented keys.

No timing assertions (the numbers depend on the machine and its load)."""

import importlib.util
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("sdc_throughput", ROOT / "benchmarks" / "sdc_throughput.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_core_function_keys_and_positive_numbers(bench):
    res = bench.run(ns=(1, 4), offline_s=0.02, realtime_s=0.01, n_max=4, goal=4)
    json.dumps(res)  # JSON-able
    for key in ("machine", "parameters", "steps_per_s", "max_instances_realtime", "realtime_probes",
                "goal_realtime", "goal_met"):
        assert key in res
    for key in ("platform", "cpu_count", "python", "numpy"):
        assert res["machine"][key]
    assert res["parameters"]["ts_s"] == pytest.approx(0.67e-3)
    assert set(res["steps_per_s"]) == {"1", "4"}
    for row in res["steps_per_s"].values():
        for key in ("steps_per_s", "steps_per_s_with_wire", "us_per_step", "us_per_step_with_wire"):
            assert row[key] > 0
    assert 0 <= res["max_instances_realtime"] <= 4
    for probe in res["realtime_probes"]:
        assert probe["rounds"] > 0 and probe["round_us_p50"] > 0
        assert 0.0 <= probe["late_fraction"] <= 1.0


def test_service_round_produces_ctrl_packets(bench):
    r = bench.ServiceRound(3)
    assert r.full() == 3 * 60  # three CTRL datagrams of 15 words with the VILLAS header


def test_bank_step_with_no_slots_returns_empty_outputs():
    import numpy as np

    from sdc_unit.bank import ControllerBank
    from sdvisc.vocabulary import MEAS_FIELDS

    bank = ControllerBank(capacity=3, step_s=0.67e-3)
    out, valid = bank.step(np.array([], dtype=int), {k: np.zeros(0) for k in MEAS_FIELDS})
    assert valid.shape == (0,) and out["v_ref_d"].shape == (0,)


def test_round_cost_benchmark_answers_every_measurement_once():
    spec = importlib.util.spec_from_file_location("sdc_round_cost", ROOT / "benchmarks" / "sdc_round_cost.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    for mode in ("single", "batch"):
        res = mod.run_memory(3, mode, rounds=12, warm=3)
        assert res["ctrl_sent"] == res["ctrl_expected"] and not res["rejected"]
        assert res["cpu_us_per_round"] > 0
