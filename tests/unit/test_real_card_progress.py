"""Issue 42 item 8: with a real card (which writes no status for us) the progress line's time comes
from the run's clock and its counts say n/a, not 0; an emulated card's or the plant's status is
shown as written. The clock is injected."""

from __future__ import annotations

import json
from types import SimpleNamespace

from scenarios.cli_ext import status_header
from scenarios.feedback import progress_line
from scenarios.run_state import RunState


class _Clock:
    def __init__(self, now: float) -> None:
        self.t = now

    def now(self) -> float:
        return self.t


def _state(tmp_path, emulate: bool | None) -> RunState:
    state = RunState()
    peer = None if emulate is None else SimpleNamespace(emulate=emulate)
    state.out, state.t0, state.clock = tmp_path, 100.0, _Clock(102.5)
    state.scenario = SimpleNamespace(plant=SimpleNamespace(peer=peer))
    return state


def test_a_real_cards_progress_runs_on_the_run_clock(tmp_path):
    state = _state(tmp_path, emulate=False)
    assert state.plant_status() == {"t_sim": 2.5}
    line = progress_line(state.progress_status(), 5.0)
    assert "t=  2.50/5.00 s" in line and "meas_tx=n/a" in line and "ctrl_rx=n/a" in line and "late=n/a" in line
    state.clock.t = 99.0  # before t = 0
    assert state.plant_status() == {"t_sim": 0.0}


def test_a_written_status_is_shown_as_it_is(tmp_path):
    (tmp_path / "gtnet_card_status.json").write_text(json.dumps({"t_sim": 1.25, "meas_tx": 10, "ctrl_rx": 9}))
    for emulate in (True, None):
        line = progress_line(_state(tmp_path, emulate).progress_status(), 5.0)
        assert "t=  1.25/5.00 s" in line and "meas_tx=10" in line and "ctrl_rx=9" in line
    assert _state(tmp_path / "none", None).plant_status() is None  # no status written yet: nothing invented


def test_the_cli_status_of_a_real_cards_run_says_n_a_not_0(tmp_path):
    line = status_header(_state(tmp_path, emulate=False).progress_status(), 5.0)
    assert line.startswith("t_sim=2.50 s (timeline 5 s)")
    assert "late_steps=n/a" in line and "meas_tx=n/a" in line and "ctrl_rx=n/a" in line
    (tmp_path / "plant_status.json").write_text(json.dumps({"t_sim": 1.0, "late_steps": 0, "meas_tx": 7, "ctrl_rx": 6}))
    assert "meas_tx=7  ctrl_rx=6" in status_header(_state(tmp_path, emulate=None).progress_status(), None)
