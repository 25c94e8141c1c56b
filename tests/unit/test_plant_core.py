"""The plant service's core (plant.service.core.PlantCore) driven without sockets: datagrams and an
injected ``now`` in, datagrams, events and counters out, on the minimal plant model."""

from __future__ import annotations

import ast
import inspect

import pytest

from plant.service import core as service_core
from plant.service.core import Pacing, PlantCore
from plant.service.model import build_model
from plant.service.summary import summarise
from sdvisc import wire
from sdvisc.config import PlantConfig

VIP = "10.0.0.254"
SDC = "10.0.0.21"
STEP = 0.001
WINDOW = 0.005  # ak_window_s
FALLBACK = 0.02  # remote_loss_fallback_s
WIDS = {"wt1_1": 101, "wt1_2": 102}


def make_core(**overrides) -> PlantCore:
    settings = {"duration_s": 1.0, "turbines": [{"name": n, "wid": w, "ip": f"10.0.1.{w - 100}"} for n, w in WIDS.items()],
                "out_dir": "unused", "step_s": STEP, "controller_vip": VIP, "ak_period_s": 0.01, "ak_window_s": WINDOW,
                "remote_loss_fallback_s": FALLBACK, **overrides}
    cfg = PlantConfig(**settings)
    model, indices = build_model(cfg, [t.name for t in cfg.turbines])
    return PlantCore(cfg, model, indices)


def request(cmd: int, wid: int = 101) -> bytes:
    values = {"req_id": 1, "cmd": int(cmd), "wt": wid, "sdc_ip": wire.ip_to_i32(SDC), "mask": 0, "h": 0.0, "d": 0.0,
              "m_q": 0.0, "v_ref": 0.0, "q_ref": 0.0, "supp": 0}
    return wire.encode(wire.MsgType.REQUEST, values, header=wire.Header(1, 2, 3))


def ctrl(meas_seq: int, now: float, i=(0.3, 0.1), wid: int = 101) -> bytes:
    values = {"wt": wid, "seq": meas_seq, "meas_seq": meas_seq, "v_ref_d": 1.0, "v_ref_q": 0.05, "i_ref_d": i[0],
              "i_ref_q": i[1], "delta": 0.2, "omega": 1.0, "e_mag": 1.01, "flags": 0}
    sec = int(now)
    return wire.encode(wire.MsgType.CTRL, values, header=wire.Header(meas_seq, sec, int((now - sec) * 1e9)))


def decoded(out) -> list[tuple[str, wire.Message, tuple]]:
    return [(ep.name, wire.decode(data, header=True), addr) for ep, data, addr in out]


def started(core: PlantCore, now: float = 0.0) -> None:
    core.receive(core.endpoints[0], request(wire.Command.STREAM_START), (VIP, wire.PORT_CONTROLLER), now)


def test_the_core_opens_no_socket_thread_clock_or_file():
    tree = ast.parse(inspect.getsource(service_core))
    imported = {alias.name.split(".")[0] for node in ast.walk(tree) if isinstance(node, ast.Import) for alias in node.names}
    imported |= {node.module.split(".")[0] for node in ast.walk(tree) if isinstance(node, ast.ImportFrom) and node.module}
    assert not imported & {"socket", "select", "selectors", "threading", "time", "os", "io", "subprocess"}
    assert "open(" not in inspect.getsource(service_core)


def test_nothing_is_sent_before_the_stream_starts_then_a_meas_every_step_with_increasing_seq():
    core = make_core()
    assert core.step(0.0) == [] and core.k == 1
    started(core, 0.001)
    ep = core.endpoints[0]
    assert ep.streaming and ep.sdc_addr == (SDC, wire.PORT_SDC) and core.model.mode[0] == 1  # remote
    assert core.events_applied == [{"t": 0.001, "type": "stream_start", "wt": "wt1_1", "sdc": SDC}]
    seqs = []
    for k in range(1, 31):
        now = k * STEP
        meas = [(msg, addr) for name, msg, addr in decoded(core.step(now)) if msg.type == wire.MsgType.MEAS]
        assert len(meas) == 1  # the other turbine does not stream
        msg, addr = meas[0]
        assert addr == (SDC, wire.PORT_SDC) and msg["wt"] == 101 and msg["t_sim"] == pytest.approx(core.k * STEP)
        assert (msg.header.sec, msg.header.nsec) == (int(now), int((now - int(now)) * 1e9))
        seqs.append(msg["seq"])
    assert seqs == list(range(1, 31)) and ep.meas_seq == 30
    assert ep.counts["meas_tx"] == 30 and ep.first_meas_tx_t == pytest.approx(2 * STEP)
    core.receive(ep, request(wire.Command.STREAM_STOP), (VIP, wire.PORT_CONTROLLER), 0.031)
    assert core.step(0.031) == [] and core.model.mode[0] == 0 and core.events_applied[-1]["type"] == "stream_stop"


def test_a_ctrl_is_applied_and_held_and_ak_1_within_the_window_then_0_after_it():
    core = make_core()
    ep = core.endpoints[0]
    started(core)
    aks = []  # (now, ak)

    def step(now):
        for _, msg, addr in decoded(core.step(now)):
            if msg.type == wire.MsgType.AK:
                assert addr == (VIP, wire.PORT_CONTROLLER) and msg["wt"] == 101 and msg["seq"] == ep.ak_seq
                aks.append((now, msg["ak"]))

    step(0.0)
    assert aks == [(0.0, 0)]  # the first AK: no control yet
    t_ctrl = 0.0004
    core.receive(ep, ctrl(ep.meas_seq, t_ctrl - 0.0003), (SDC, wire.PORT_SDC), t_ctrl)
    assert ep.counts["ctrl_rx"] == 1 and ep.rtt_samples[0] == 1 and ep.ctrl_delays_ms == [pytest.approx(0.3)]
    assert core.events_applied[-1]["type"] == "ctrl_started"
    step(0.001)
    assert aks[-1] == (0.001, 1)  # at once: it changed
    assert core.model.remote_i[0] == pytest.approx(0.3 + 0.1j)
    for k in range(2, 18):  # 17 ms < remote_loss_fallback_s
        step(k * STEP)
    # held: no new CTRL, the last one still applied (the model's loss time is not over)
    assert core.model.mode[0] == 1 and core.model.remote_i[0] == pytest.approx(0.3 + 0.1j)
    assert abs(core.model.i[0] - (0.3 + 0.1j)) < 0.8 * abs(0.8 - (0.3 + 0.1j))  # the converter follows it from P* = 0.8
    ones = [now for now, ak in aks if ak == 1]
    zeros_after = [now for now, ak in aks if ak == 0 and now > t_ctrl]
    assert all(now - t_ctrl <= WINDOW for now in ones)
    assert zeros_after and t_ctrl + WINDOW < zeros_after[0] <= t_ctrl + WINDOW + STEP  # at once when it changes
    # then every ak_period_s: at the steps k = 10, 20, … (``now`` is the step's start, k - 1 steps)
    assert [now for now, _ in aks if now > zeros_after[0]] == pytest.approx([0.009])
    assert ep.ak_ones == len(ones) and ep.counts["ak_tx"] == len(aks)


def test_malformed_and_foreign_datagrams_are_counted_and_never_applied():
    core = make_core()
    ep = core.endpoints[0]
    started(core)
    core.step(0.0)
    before = core.model.remote_i[0]
    core.receive(ep, b"\x00" * 9, (SDC, wire.PORT_SDC), 0.0005)  # length
    core.receive(ep, ctrl(1, 0.0004, i=(0.9, 0.9)), ("10.0.9.9", wire.PORT_SDC), 0.0005)  # not_from_sdc
    core.receive(ep, ctrl(1, 0.0004, i=(0.9, 0.9), wid=102), (SDC, wire.PORT_SDC), 0.0005)  # wrong_turbine
    core.receive(ep, ctrl(1, 0.0004, i=(20.0, 0.0)), (SDC, wire.PORT_SDC), 0.0005)  # out_of_range
    core.receive(ep, ctrl(5, 0.0004, i=(0.9, 0.9)), (SDC, wire.PORT_SDC), 0.0005)  # future_seq
    core.receive(ep, request(wire.Command.STREAM_STOP), ("10.0.9.9", wire.PORT_CONTROLLER), 0.0005)  # not_from_controller
    out = decoded(core.step(0.001))
    assert ep.streaming and core.model.remote_i[0] == before and ep.counts["ctrl_rx"] == 0
    assert [msg["ak"] for _, msg, _ in out if msg.type == wire.MsgType.AK] == []  # still 0: unchanged, not due
    rejected = {k[len("rx_reject_"):]: n for k, n in ep.counts.items() if k.startswith("rx_reject_")}
    assert rejected == {"length": 1, "not_from_sdc": 1, "wrong_turbine": 1, "out_of_range": 1, "future_seq": 1,
                        "not_from_controller": 1}
    assert ep.counts["rx_rejected"] == 6 and core.rx_stats.length == 1 and core.rx_stats.ok == 6


def test_a_streaming_turbine_falls_back_after_remote_loss_fallback_s_without_ctrl():
    core = make_core()
    ep = core.endpoints[0]
    started(core)
    core.step(0.0)
    core.receive(ep, ctrl(1, 0.0005), (SDC, wire.PORT_SDC), 0.0006)
    k = 1
    while core.model.mode[0] == 1 and k < 100:
        core.receive(ep, b"\xff" * 7, ("10.0.9.9", 1), k * STEP)  # only garbage from now on
        core.step(k * STEP)
        k += 1
    # the model applied the CTRL at step 1, then counted FALLBACK of silence
    assert core.model.fallbacks[0] == 1 and (k - 1) * STEP == pytest.approx(FALLBACK + STEP, abs=1.5 * STEP)
    assert ep.streaming and ep.meas_seq == k  # the turbine keeps measuring: the SDN app decides
    summary = summarise(core, Pacing(STEP), {"f_pcc_hz": {}, "batteries": {}})
    assert summary["fallbacks"] == {"wt1_1": 1} and summary["steps"] == k
    assert summary["rx_rejected"] == {"length": k - 1}
    assert summary["turbines"]["wt1_1"]["ctrl_rx"] == 1 and summary["turbines"]["wt1_2"]["meas_tx"] == 0


def test_a_refused_send_is_taken_back_from_the_counters():
    core = make_core(report_loss_after_s=0.003)
    ep = core.endpoints[0]
    started(core)
    out = core.step(0.0)
    assert [addr for _, _, addr in out] == [(SDC, wire.PORT_SDC), (VIP, wire.PORT_CONTROLLER)]
    for e, _, addr in out:  # the socket refused both
        core.send_failed(e, addr)
    assert (ep.counts["meas_tx"], ep.counts["meas_tx_error"], ep.counts["ak_tx"], ep.first_meas_tx_t) == (0, 1, 0, None)
    assert ep.ak_seq == 1 and ep.meas_seq == 1  # the sequence numbers were used
    core.step(0.001)
    assert (ep.counts["meas_tx"], ep.first_meas_tx_t) == (1, pytest.approx(2 * STEP))
    # a loss as long as report_loss_after_s (3 ms, inside the 5 ms AK window) is reported at once, once
    core.receive(ep, ctrl(ep.meas_seq, 0.0014), (SDC, wire.PORT_SDC), 0.0015)
    aks = [(k * STEP, msg["ak"]) for k in range(2, 9) for _, msg, _ in decoded(core.step(k * STEP))
           if msg.type == wire.MsgType.AK]
    assert aks == [(0.002, 1), (0.005, 1), (0.007, 0)] and ep.loss_reported


def test_scenario_events_and_stop():
    core = make_core()
    core.step(0.0)
    core.apply_event({"type": "fault", "on": True})
    assert core.model.v_grid == 0.3
    core.apply_event({"type": "set", "param": "grid_voltage", "delta": 0.05})
    assert core.events_applied[-1] == {"t": STEP, "type": "set", "param": "grid_voltage", "delta": 0.05,
                                       "before": 0.3, "value": pytest.approx(0.35)}
    assert not core.stop_requested
    core.apply_event({"type": "stop"})
    assert core.stop_requested
    with pytest.raises(ValueError, match="cannot apply"):
        core.apply_event({"type": "teleport"})


def test_pacing_records_late_steps_and_stalls():
    pacing = Pacing(STEP)
    for k, late in enumerate([0.0, 0.0005, 0.002, 0.02, 0.015, 0.0, 0.03]):
        pacing.note(k, late)
    assert pacing.late_steps == 4 and pacing.max_lateness_s == 0.03
    assert pacing.stalls == [[0.003, 20.0, 4], [0.006, 30.0, 6]]


def test_a_step_that_reports_aks_sends_every_meas_first():
    """50 AKs encoded between the MEAS of a step held up the last turbines' MEAS (and so their CTRL)."""
    core = make_core()
    for ep in core.endpoints:
        core.receive(ep, request(wire.Command.STREAM_START, wid=ep.wid), (VIP, wire.PORT_CONTROLLER), 0.0)
    kinds = []
    for k in range(1, 12):  # an AK period (10 steps) and more
        kinds.append([msg.type for _, msg, _ in decoded(core.step(k * STEP))])
    with_aks = [step for step in kinds if wire.MsgType.AK in step]
    assert with_aks, "an AK period passed"
    for step in with_aks:
        first_ak = step.index(wire.MsgType.AK)
        assert step[:first_ak] == [wire.MsgType.MEAS] * len(core.endpoints)
        assert set(step[first_ak:]) == {wire.MsgType.AK}
