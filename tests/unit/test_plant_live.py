"""What the plant publishes while it runs (plant.service.live): the control-packet events a session's
feedback is built on, and the status file with each ViSC turbine's V, Q, f."""

from __future__ import annotations

import json

import numpy as np
import pytest

from plant.service.core import Endpoint
from plant.service.live import LOSS_REPORT_S, LivePublisher

T0 = 1000.0


def streaming_endpoint(now: float) -> Endpoint:
    ep = Endpoint("wt1_1", 101, 0)
    ep.streaming, ep.awaiting_first_ctrl, ep.stream_started_wall = True, True, now
    return ep


def ctrl(live: LivePublisher, ep: Endpoint, now: float) -> None:
    live.on_ctrl(ep, now)  # what PlantCore._on_ctrl does, in this order
    ep.last_ctrl_wall = now


def test_first_packet_then_a_loss_reported_once_then_its_end(tmp_path):
    events: list[dict] = []
    live = LivePublisher(tmp_path, events)
    live.t0 = T0
    ep = streaming_endpoint(T0 + 1.0)
    live.check_losses([ep], T0 + 1.05)
    assert events == []  # no packet yet: nothing can be lost
    ctrl(live, ep, T0 + 1.002)
    assert events[-1] == {"t": 1.002, "type": "ctrl_started", "wt": "wt1_1", "after_ms": pytest.approx(2.0)}
    for k in range(1, 100):  # every 0.67 ms: no loss
        ctrl(live, ep, T0 + 1.002 + k * 0.00067)
    live.check_losses([ep], T0 + 1.07)
    assert len(events) == 1
    last = T0 + 1.002 + 99 * 0.00067
    live.check_losses([ep], last + LOSS_REPORT_S / 2)
    assert len(events) == 1  # 10 ms of silence is not a loss
    live.check_losses([ep], last + LOSS_REPORT_S)
    live.check_losses([ep], last + 3 * LOSS_REPORT_S)
    assert [e["type"] for e in events] == ["ctrl_started", "ctrl_lost"]  # once
    assert events[1]["t_loss"] == pytest.approx(last - T0)
    ctrl(live, ep, last + 0.047)
    assert events[2] == {"t": pytest.approx(last + 0.047 - T0), "type": "ctrl_restored", "wt": "wt1_1",
                         "t_loss": pytest.approx(last - T0), "gap_ms": pytest.approx(47.0)}
    lines = [json.loads(line) for line in (tmp_path / "plant_events.jsonl").read_text().splitlines()]
    assert [e["type"] for e in lines] == ["ctrl_started", "ctrl_lost", "ctrl_restored"]  # as they happened


def test_a_short_gap_is_no_event_and_a_gap_between_checks_still_ends_in_restored(tmp_path):
    events: list[dict] = []
    live = LivePublisher(None, events)
    live.t0 = T0
    ep = streaming_endpoint(T0)
    ctrl(live, ep, T0 + 0.001)
    ctrl(live, ep, T0 + 0.012)  # 11 ms: jitter
    ctrl(live, ep, T0 + 0.040)  # 28 ms, never seen by check_losses: still reported at its end
    assert [e["type"] for e in events] == ["ctrl_started", "ctrl_restored"] and events[1]["gap_ms"] == pytest.approx(28.0)


def test_status_has_v_q_f_and_delay_of_streaming_turbines_only(tmp_path):
    class Model:
        def measurements(self):
            return {"v_d": np.array([0.6, 1.0, 1.0]), "v_q": np.array([0.8, 0.0, 0.0]), "p": np.array([0.5, 0.0, 0.0]),
                    "q": np.array([0.1, 0.0, 0.0]), "omega_meas": np.array([1.002, 1.0, 1.0])}

    class Core:
        k, step_s, n_steps, model = 1500, 0.001, None, Model()

    on = Endpoint("wt1_1", 101, 0)
    on.streaming, on.last_ctrl_wall, on.live_delay = True, T0 + 1.4, [1.5, 3]
    off = Endpoint("wt1_2", 102, 1)  # streamed before, stopped
    off.counts.update(meas_tx=40, ctrl_rx=38)
    idle = Endpoint("wt1_3", 103, 2)  # never took part: left out
    Core.endpoints = [on, off, idle]
    live = LivePublisher(tmp_path, [])
    live.t0 = T0
    live.write_status(Core, T0 + 1.5, late_steps=3)
    live.close()  # the status is written in the background; close writes the last one
    status = json.loads((tmp_path / "plant_status.json").read_text())
    assert status["t_sim"] == 1.5 and status["n_steps"] is None and status["late_steps"] == 3 and status["streaming"] == ["wt1_1"]
    row = status["turbines"]["wt1_1"]
    assert (row["v"], row["q"], row["p"], row["f_hz"], row["ctrl_delay_ms"]) == (1.0, 0.1, 0.5, 50.1, 0.5)
    assert row["t_last_ctrl"] == pytest.approx(1.4)
    assert status["turbines"]["wt1_2"] == {"streaming": False, "meas_tx": 40, "ctrl_rx": 38}
    assert "wt1_3" not in status["turbines"]
    assert on.live_delay == [0.0, 0]  # the delay is the mean since the last status
