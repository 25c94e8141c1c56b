"""``time_scale: auto``: the choice of k from measured costs, the temporary pilot rules (followed hop
by hop on the real topology descriptions), the kernel receive stamps, and the SDC pilot (the real
SDC service) answering MEAS over real UDP."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import time

import networkx as nx
import pytest

from scenarios.calibrate import (
    BUSY_LIMIT,
    CANDIDATES,
    PROBE_COOKIE_TEXT,
    ROUND_TRIP_LIMIT_STEPS,
    VISC_SAMPLE_WALL_S,
    borderline,
    choose,
    first_guess,
    pilot_flows,
    search,
    shortfalls,
)
from scenarios.summary import round_trip, time_advice
from sdvisc import rxstamp, wire
from sdvisc.config import SdcConfig, write_config
from topologies import topos
from topologies.base import describe

TS = 0.67e-3


def test_real_time_passes_when_everything_fits():
    assert shortfalls(1, TS, plant_step_s=0.1 * TS, sdc_busy=0.1, worst_answer_p99_wall_s=0.3 * TS) == []


def test_a_trial_decided_by_its_last_per_cent_is_borderline():
    quiet = [2.0] * 198  # ms
    one_stall = {"wt1_1": quiet + [9.0, 8.5], "wt2_1": quiet + [9.0, 8.5]}  # one stall: the same 2 samples everywhere
    assert borderline(one_stall, 5e-3)  # p98 2 ms within 5 ms, p99.5 ≈ 9 ms beyond: too close to call
    assert not borderline(one_stall, 10e-3)  # within the budget either way
    assert not borderline({"wt1_1": [6.0] * 200}, 5e-3)  # beyond it either way: the trial's verdict stands
    slow_far_turbine = {"wt1_1": [2.0] * 200, "wt3_1": [2.0] * 190 + [6.0] * 10}  # 5 % slow: not a few samples
    assert not borderline(slow_far_turbine, 5e-3)
    assert not borderline({"wt1_1": []}, 5e-3)


@pytest.mark.parametrize("k", CANDIDATES)
def test_each_limit_is_applied_in_simulated_time(k):
    period = k * TS
    assert shortfalls(k, TS, BUSY_LIMIT * period * 1.01, 0.0, None)[0].startswith("plant")
    assert shortfalls(k, TS, 0.0, BUSY_LIMIT * 1.01, None)[0].startswith("SDC")
    assert shortfalls(k, TS, BUSY_LIMIT * period * 0.99, BUSY_LIMIT * 0.99, None) == []
    # the plant's step and the round trip together must fit in the share of a sample, in simulated time
    limit_wall = ROUND_TRIP_LIMIT_STEPS * TS * k
    assert shortfalls(k, TS, 0.0, 0.0, limit_wall * 0.99) == []
    assert "step start -> CTRL" in shortfalls(k, TS, 0.0, 0.0, limit_wall * 1.01)[0]
    # the answer time counts from the step's start: the step's work is in it already, not added again
    assert shortfalls(k, TS, 0.3 * limit_wall, 0.0, 0.99 * limit_wall) == []
    assert "missing" in shortfalls(k, TS, 0.0, 0.0, None, lost=3)[0]


def test_choose_takes_the_smallest_passing_k_else_the_largest_tried():
    assert choose([{"k": 1, "ok": False}, {"k": 2, "ok": False}, {"k": 4, "ok": True}]) == (4.0, True)
    assert choose([{"k": 1, "ok": True}]) == (1.0, True)
    assert choose([{"k": k, "ok": False} for k in CANDIDATES]) == (64.0, False)


def test_the_first_guess_is_the_largest_candidate_at_or_below_the_one_core_need():
    step = 0.67e-3
    for n in (0, 1, 4, 16, 50, 500):
        k, need = first_guess(n, step), n * VISC_SAMPLE_WALL_S / step  # the k whose sample holds it on one core
        assert k in CANDIDATES
        assert k == CANDIDATES[0] or k <= need
        assert k == CANDIDATES[-1] or CANDIDATES[CANDIDATES.index(k) + 1] > need
    assert first_guess(50, step) == 8 and first_guess(4, step) == 1


def test_searching_from_the_guess_finds_what_searching_from_one_finds_in_fewer_trials():
    for smallest in CANDIDATES:
        trial = lambda k, s=smallest: {"k": k, "ok": k >= s}  # noqa: E731
        from_one, from_guess = search(trial), search(trial, first_guess(50, 0.67e-3))
        assert choose(from_one) == choose(from_guess) == (float(smallest), True)
        if smallest >= 8:
            assert len(from_guess) < len(from_one)


def _walk(desc: dict, flows: dict, src_switch: str, dst_host: str, match: str) -> list[str]:
    """Follow the probe rules from ``src_switch`` to ``dst_host``; a non-OpenFlow (learning) switch
    forwards toward the destination as it will once it has learned the MAC."""
    g = nx.Graph()
    by_port = {}
    for link in desc["links"]:
        g.add_edge(link["a"], link["b"])
        by_port[(link["a"], link["a_port"])] = link["b"]
        by_port[(link["b"], link["b_port"])] = link["a"]
    for name, h in desc["hosts"].items():
        g.add_edge(name, h["switch"])
        by_port[(h["switch"], h["port"])] = name
    node, seen = src_switch, [src_switch]
    while node != dst_host:
        assert len(seen) < 50, f"probe loops: {seen}"
        if desc["switches"][node]["openflow"]:
            rules = [r for r in flows.get(node, []) if match in r]
            assert len(rules) == 1, f"{node}: {len(rules)} rules for {match}"
            assert rules[0].startswith(PROBE_COOKIE_TEXT)
            node = by_port[(node, int(rules[0].rsplit("output:", 1)[1]))]
        else:
            node = nx.shortest_path(g, node, dst_host)[1]
        seen.append(node)
    return seen


@pytest.mark.parametrize(("name", "params", "turbines"), [
    ("paper", {}, ["wt1_1"]),
    ("paper", {"clusters": 5, "turbines": 2}, ["wt1_1", "wt3_2", "wt5_1"]),
    ("farm", {}, ["wt1_1", "wt2_1", "wt3_1", "wt5_1"]),
    ("farm", {"clusters": 5, "turbines": 10, "layout": "tower"}, ["wt1_10", "wt4_3"]),
])
def test_pilot_rules_carry_each_turbine_to_the_sdc_and_back(name, params, turbines):
    desc = describe(topos[name](**params))
    hosts = desc["hosts"]
    flows = pilot_flows(desc, "sdc1", turbines)
    g = nx.Graph([(link["a"], link["b"]) for link in desc["links"]])
    for wt in turbines:
        out = _walk(desc, flows, hosts[wt]["switch"], "sdc1", f"nw_dst={hosts['sdc1']['ip']},tp_dst={wire.PORT_SDC}")
        back = _walk(desc, flows, hosts["sdc1"]["switch"], wt, f"nw_dst={hosts[wt]['ip']},tp_dst={wire.PORT_TURBINE}")
        shortest = nx.shortest_path_length(g, hosts[wt]["switch"], hosts["sdc1"]["switch"])
        assert len(out) - 2 == shortest and len(back) - 2 == shortest  # hop count of the first path


def test_pilot_rules_name_only_openflow_switches_and_a_missing_path_is_an_error():
    desc = describe(topos["paper"]())
    flows = pilot_flows(desc, "sdc1", ["wt1_1"])
    assert set(flows) <= {n for n, s in desc["switches"].items() if s["openflow"]}
    desc["links"] = []  # every turbine cut off
    with pytest.raises(ValueError, match="no path from wt1_1"):
        pilot_flows(desc, "sdc1", ["wt1_1"])


def test_the_sdc_pilot_serves_meas_over_udp_and_the_kernel_stamps_the_answer(tmp_path):
    """The real SDC service, started as the calibration starts it, answers each MEAS of a served
    turbine with its CTRL; the receive stamp is the kernel's, after the send."""
    cfg = SdcConfig(step_s=TS, controller_vip="10.0.0.254", out_dir=str(tmp_path), sdc_id=1, role="primary",
                    capacity=4, bind_ip="127.0.9.1", realtime_priority=False)
    cfg_path = write_config(cfg, tmp_path / "sdc.json")
    ready = tmp_path / "ready.json"
    pilot = subprocess.Popen([sys.executable, "-m", "sdc_unit.pilot", "--config", str(cfg_path), "--serve", "101",
                              "--ready", str(ready)])
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        deadline = time.time() + 60
        while not ready.exists():
            assert pilot.poll() is None and time.time() < deadline, "the pilot did not start"
            time.sleep(0.05)
        sock.bind(("127.0.9.2", wire.PORT_TURBINE))  # the SDC answers the MEAS's source at the turbine port
        rxstamp.enable(sock)
        sock.settimeout(10)
        meas = {"v_d": 1.0, "v_q": 0.0, "i_d": 0.5, "i_q": 0.1, "p": 0.5, "q": -0.1, "v_dc": 1.0, "omega_meas": 1.0}
        answers = []
        for seq in range(1, 4):
            t_send = time.time_ns()
            sock.sendto(wire.encode(wire.MsgType.MEAS, {"wt": 101, "seq": seq, "t_sim": seq * TS, **meas},
                                    header=wire.Header.at(seq, time.time())), ("127.0.9.1", wire.PORT_SDC))
            data, _addr, t_rx = rxstamp.recv(sock)
            answers.append(wire.decode(data, header=True))
            assert t_rx > t_send
        assert [m.type for m in answers] == [wire.MsgType.CTRL] * 3
        assert [m["meas_seq"] for m in answers] == [1, 2, 3] and all(m["wt"] == 101 for m in answers)
    finally:
        sock.close()
        pilot.terminate()
        pilot.wait(timeout=20)
    done = json.loads(ready.read_text())
    assert done["done"] and done["served"] == {"wt1_1": 3} and done["cpu_s"] > 0


def test_nothing_waiting_is_none_not_an_error():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.bind(("127.0.0.1", 0))
        sock.setblocking(False)
        rxstamp.enable(sock)
        assert rxstamp.recv(sock) is None


def test_round_trip_histogram_summary():
    assert round_trip(None) is None
    rt = round_trip({"2": 10, "1": 89, ">7": 1})
    assert list(rt["counts"]) == ["1", "2", ">7"] and rt["within_one"] == 0.89 and rt["median"] == "1"
    assert round_trip({"1": 10, "3": 30})["median"] == "3"


def test_late_steps_advice_names_a_larger_time_scale():
    assert time_advice(2, 1000, 10) is None
    assert "--time-scale 4" in time_advice(2, 1000, 11)
    assert time_advice(1, 0, 0) is None
    assert time_advice(4, 1000, 0, {"wt1_1": 0.995, "wt2_1": 0.99}) is None
    said = time_advice(4, 1000, 0, {"wt1_1": 0.98, "wt3_1": 0.74})
    assert "26.0% of wt3_1's answers" in said and "--time-scale 8" in said


def test_scenario_time_scale_is_a_number_or_auto(tmp_path):
    from scenarios.loader import ScenarioError, load_scenario

    base = "name: t\nduration_s: 1\n"
    for good, want in (("auto", "auto"), ("4", 4.0)):
        path = tmp_path / f"{good}.yaml"
        path.write_text(base + f"time_scale: {good}\n")
        assert load_scenario(path).time_scale == want
    path = tmp_path / "bad.yaml"
    path.write_text(base + "time_scale: fast\n")
    with pytest.raises(ScenarioError, match=r"bad.yaml:3: time_scale"):
        load_scenario(path)
