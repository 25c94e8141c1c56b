"""How close each candidate k of ``time_scale: auto`` came: within one sample (worst turbine and
median), within the pilot's limit, late steps and the share of the limit the p99 used — and the
terminal line and summary rows built from them."""

from __future__ import annotations

import pytest

from scenarios.calibration_cache import CalibrationCache, choose_time_scale
from scenarios.calibration_report import candidate_line, candidates, candidates_line, closeness

PERIOD_S = 8 * 0.67e-3  # k = 8: one sample is 5.36 ms of wall time
LIMIT_S = 0.75 * PERIOD_S


def test_fractions_count_the_answers_within_one_sample_and_the_missing_ones_as_late():
    answers = {"wt1_1": [2.0] * 99 + [6.0],  # one answer beyond 5.36 ms
               "wt1_2": [2.0] * 90 + [4.5] * 8,  # 8 beyond the 4.02 ms limit, 2 never answered
               "wt1_3": [1.0] * 100}
    near = closeness(answers, 100, PERIOD_S, LIMIT_S, [0.0] * 100, 4.5e-3)
    one = near["within_one_sample"]
    assert one["worst"] == 0.98 and one["worst_turbine"] == "wt1_2"  # the missing answers count as late
    assert one["median"] == 0.99
    limit = near["within_limit"]
    assert limit["worst"] == 0.90 and limit["worst_turbine"] == "wt1_2" and limit["median"] == 0.99
    assert near["limit_used"] == pytest.approx(4.5e-3 / LIMIT_S, abs=1e-3)  # over 1: the trial fails by that much
    assert near["late_steps"] == 0


def test_late_steps_are_those_begun_more_than_one_period_behind_their_schedule():
    lateness = [0.0, 0.5 * PERIOD_S, 1.5 * PERIOD_S, 3.0 * PERIOD_S, 0.99 * PERIOD_S]
    near = closeness({"wt1_1": [1.0] * 5}, 5, PERIOD_S, LIMIT_S, lateness, 1e-3)
    assert near["late_steps"] == 2
    assert near["max_lateness_samples"] == 3.0


def test_no_visc_turbine_gives_no_fractions_and_no_limit_share():
    near = closeness({}, 200, PERIOD_S, LIMIT_S, [], None)
    assert near["within_one_sample"]["worst"] is None and near["limit_used"] is None and near["late_steps"] == 0


def _trial(k: float, ok: bool, worst: float, median: float, used: float, late: int = 0) -> dict:
    near = {"within_one_sample": {"worst": worst, "worst_turbine": "wt5_6", "median": median},
            "within_limit": {"worst": worst, "worst_turbine": "wt5_6", "median": median},
            "late_steps": late, "max_lateness_samples": 0.0, "limit_used": used}
    why = [] if ok else ["step start -> CTRL p99 0.523 ms simulated (limit 0.503 ms = 0.75 Ts)"]
    return {"k": k, "ok": ok, "why_not": why, "plant_busy": 0.3, "sdc_busy": 0.17, "answer_p99_sim_ms": 0.5,
            "closeness": near}


def test_the_line_says_how_close_each_candidate_came_smallest_first():
    trials = [_trial(16, True, 1.0, 1.0, 0.49), _trial(8, False, 0.972, 0.989, 1.04, late=3)]
    line = candidates_line(trials)
    assert line.index("k = 8") < line.index("k = 16")
    assert "k = 8 fell short: p99 104% of the limit; worst turbine wt5_6 97.2% within one sample " \
           "(median 98.9%); 3 late steps" in line
    assert "k = 16 passed: p99 49% of the limit" in line
    assert candidate_line({"k": 4, "ok": False, "why_not": []}) == "k = 4 fell short"  # an old trial without it


def test_summary_rows_and_the_terminal_line_carry_every_candidate(tmp_path):
    trials = [_trial(8, False, 0.972, 0.989, 1.04), _trial(16, True, 0.999, 1.0, 0.49)]
    rows = candidates(trials)
    assert [(r["k"], r["ok"], r["limit_used"], r["within_one_sample_worst"]) for r in rows] == [
        (8, False, 1.04, 0.972), (16, True, 0.49, 0.999)]

    class Run:  # what choose_time_scale reads of a run
        datapath = "netdev"
        recalibrate = True

        class scenario:  # noqa: N801 - stands in for the Scenario object
            name = "all_visc_50"
            timeline = []

            @staticmethod
            def model_dump(mode):
                keys = ("topology", "step_s", "plant", "sdc", "sdn", "switch_ports", "switch_links", "cpu_split",
                        "switch_revalidation_ms", "links", "impairable")
                return dict.fromkeys(keys)

    measured = {"time_scale": 16.0, "met": True, "trials": trials, "candidates": rows, "wall_s": 5.3}
    cal = choose_time_scale(Run(), CalibrationCache(tmp_path / "c.json"), measure=lambda: measured)
    line = cal["line"]
    assert "\n" not in line and line.startswith("sdvisc: time scale 16, calibrated in 5.3 s")
    assert "; candidates: k = 8 fell short: p99 104% of the limit" in line
    assert cal["candidates"] == rows


def test_the_pilot_steps_at_the_plant_services_scheduling_and_gives_it_back(monkeypatch):
    import os

    from scenarios.calibration_probe import plant_scheduling

    state = {"policy": os.SCHED_OTHER, "nice": 0}
    monkeypatch.setattr(os, "sched_getscheduler", lambda pid: state["policy"])
    monkeypatch.setattr(os, "sched_getparam", lambda pid: os.sched_param(0))
    monkeypatch.setattr(os, "getpriority", lambda which, who: state["nice"])
    monkeypatch.setattr(os, "sched_setscheduler", lambda pid, policy, param: state.update(policy=policy))
    monkeypatch.setattr(os, "setpriority", lambda which, who, value: state.update(nice=value))

    def to_fifo():
        state.update(policy=os.SCHED_FIFO, nice=-10)
        return "SCHED_FIFO:10"

    with pytest.raises(RuntimeError), plant_scheduling(True, raise_to=to_fifo) as got:
        assert got == "SCHED_FIFO:10" and state["policy"] == os.SCHED_FIFO
        raise RuntimeError("a trial failed")
    assert state == {"policy": os.SCHED_OTHER, "nice": 0}  # back, also when a trial raised
    with plant_scheduling(False, raise_to=to_fifo) as got:  # a plant without realtime_priority: untouched
        assert got == "default" and state["policy"] == os.SCHED_OTHER


def test_the_pilots_plant_side_measures_every_answer_of_the_real_sdc_over_udp(tmp_path):
    """The pilot's paced steps (scenarios/calibration_probe.py) send one MEAS per turbine from its own
    socket, the real SDC pilot answers each, and every answer time is measured from its step's start
    (the model: the minimal plant, two turbines in remote mode)."""
    import json
    import socket
    import subprocess
    import sys
    import time

    from plant.minimal import MinimalPlant
    from scenarios.calibration_probe import PilotSetup, probe
    from sdvisc import rxstamp, wire
    from sdvisc.config import SdcConfig, write_config

    ts = 0.67e-3
    cfg = SdcConfig(sdc_id=1, step_s=ts, controller_vip="127.0.10.254", capacity=4, bind_ip="127.0.10.1",
                    realtime_priority=False, out_dir=str(tmp_path))
    ready = tmp_path / "ready.json"
    pilot = subprocess.Popen([sys.executable, "-m", "sdc_unit.pilot", "--config", str(write_config(cfg, tmp_path / "s.json")),
                              "--serve", "101,102", "--ready", str(ready)])
    turbines = {"wt1_1": "127.0.10.2", "wt1_2": "127.0.10.3"}
    setup = PilotSetup("127.0.10.1", list(turbines), {"wt1_1": 101, "wt1_2": 102}, step_s=ts)
    try:
        deadline = time.time() + 60
        while not ready.exists():
            assert pilot.poll() is None and time.time() < deadline, "the pilot did not start"
            time.sleep(0.05)
        for wt, ip in turbines.items():
            sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            sock.bind((ip, wire.PORT_TURBINE))
            sock.setblocking(False)
            rxstamp.enable(sock)
            setup.socks[wt] = sock
        setup.model, setup.indices = MinimalPlant(2, ts), [0, 1]
        for i in setup.indices:
            setup.model.set_mode(i, "remote")
        rtt, back, answer = ({wt: [] for wt in turbines} for _ in range(3))
        period = 16 * ts  # k = 16 on loopback: every answer well within the sample
        plant_s, lateness = probe(setup, period, 50, (rtt, back, answer))
    finally:
        for sock in setup.socks.values():
            sock.close()
        pilot.terminate()
        pilot.wait(timeout=20)
    assert len(plant_s) == len(lateness) == 50 and setup.seq == 50
    assert all(len(answer[wt]) == 50 and len(rtt[wt]) == 50 for wt in turbines)  # every MEAS answered, once
    assert all(a >= r > 0 for wt in turbines for a, r in zip(answer[wt], rtt[wt]))  # the step's work comes first
    near = closeness(answer, 50, period, 0.75 * period, lateness, max(max(v) for v in answer.values()) * 1e-3)
    assert near["within_one_sample"]["worst"] is not None
    assert json.loads(ready.read_text())["served"] == {"wt1_1": 50, "wt1_2": 50}
