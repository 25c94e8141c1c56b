"""The calibration cache (scenarios/calibration_cache.py): measured once per machine, code version and
network shape, used at once afterwards, raised when a run did not hold; clock injected, no network."""

from __future__ import annotations

import json
from types import SimpleNamespace

import pytest

from scenarios.calibration_cache import (
    MAX_AGE_S,
    CalibrationCache,
    after_run,
    cache_key,
    calibration_reason,
    choose_time_scale,
    code_version,
    machine_key,
    shape_of,
)
from scenarios.loader import load_scenario
from tests.conftest import ROOT

DEFAULT = ROOT / "scenarios" / "default.yaml"


def _trial(k: float, ok: bool, why: list[str] | None = None, p99: float | None = 0.3) -> dict:
    return {"k": k, "ok": ok, "why_not": why or [], "plant_busy": 0.2, "sdc_busy": 0.1, "answer_p99_sim_ms": p99}


def _measured(k: float = 4.0) -> dict:
    trials = [_trial(1, False, ["step start -> CTRL p99 0.900 ms simulated (limit 0.503 ms = 0.75 Ts)"]),
              _trial(2, False, ["SDC 60% busy (limit 50%)"]), _trial(4, True)]
    return {"time_scale": k, "met": True, "trials": trials, "wall_s": 6.2}


class Clock:
    def __init__(self, t: float = 1.0e9) -> None:
        self.t = t

    def __call__(self) -> float:
        return self.t


def _run(scenario=None, recalibrate: bool = False):
    return SimpleNamespace(scenario=scenario or load_scenario(DEFAULT), datapath="user", recalibrate=recalibrate)


def test_the_second_run_of_a_shape_starts_from_the_cache_without_measuring(tmp_path):
    cache = CalibrationCache(tmp_path / "cal.json", now=Clock())
    calls = []

    def measure():
        calls.append(1)
        return _measured()

    first = choose_time_scale(_run(), cache, measure)
    second = choose_time_scale(_run(), cache, measure)
    assert calls == [1]
    assert first["source"] == "measured" and second["source"] == "cache"
    assert first["time_scale"] == second["time_scale"] == 4.0
    assert second["trials"] == [] and second["wall_s"] == 0.0
    assert "from the calibration cache" in second["line"] and "--recalibrate" in second["line"]
    # the one line says which k and why: the largest k that fell short, and what, and the chosen one
    assert "k = 2 fell short (SDC 60% busy" in first["line"] and "k = 4 held" in first["line"]
    assert "\n" not in first["line"] and "\n" not in second["line"]
    choose_time_scale(_run(recalibrate=True), cache, measure)
    assert calls == [1, 1]


def test_an_entry_older_than_the_limit_is_measured_again(tmp_path):
    clock = Clock()
    cache = CalibrationCache(tmp_path / "cal.json", now=clock)
    cache.remember_measured("key", _measured(), {})
    clock.t += MAX_AGE_S - 1
    assert cache.lookup("key")["time_scale"] == 4.0
    clock.t += 2
    assert cache.lookup("key") is None


def test_a_run_that_did_not_hold_doubles_the_cached_k_and_one_that_held_confirms_it(tmp_path):
    cache = CalibrationCache(tmp_path / "cal.json", now=Clock())
    cal = choose_time_scale(_run(), cache, _measured)
    assert after_run(cal, None, cache) == {"held": True, "next_run_k": None}
    assert cache.lookup(cal["cache_key"])["runs_held"] == 1
    out = after_run(cal, "MEAS->CTRL took more than one sample for 1.9% of wt1_1's answers at time scale 4: ...", cache)
    assert out == {"held": False, "next_run_k": 8.0}
    entry = cache.lookup(cal["cache_key"])
    assert entry["time_scale"] == 8.0 and entry["raised_from"] == 4.0 and "did not hold" in entry["why"]
    assert choose_time_scale(_run(), cache, _measured)["time_scale"] == 8.0
    top = CalibrationCache(tmp_path / "top.json", now=Clock())
    top.remember_measured("k", {**_measured(64.0)}, {})
    assert top.record_outcome("k", 64.0, "late") == 64.0  # never beyond the largest candidate


def test_the_key_follows_machine_code_and_network_shape_but_not_name_or_duration(tmp_path):
    sc = load_scenario(DEFAULT)
    base = shape_of(sc)
    renamed = sc.model_copy(update={"name": "other", "duration_s": 9.0, "description": "x"})
    assert shape_of(renamed) == base
    assert shape_of(sc.model_copy(update={"step_s": 1e-3})) != base
    assert shape_of(sc.model_copy(update={"switch_links": "patch"})) != base
    # a link failure later in the timeline is the same shape; other ViSC turbines are not
    assert shape_of(load_scenario(ROOT / "scenarios" / "link_failure_dr.yaml")) == base
    assert shape_of(load_scenario(ROOT / "scenarios" / "fault_4visc_network.yaml")) != base
    machine = machine_key("user")
    assert machine["cpus"] >= 1 and machine["datapath"] == "user"
    assert cache_key(machine, "c1", base) != cache_key(machine_key("system"), "c1", base)
    assert cache_key(machine, "c1", base) != cache_key(machine, "c2", base)
    # the code version: every Python file of the loop's packages, by path and content
    (tmp_path / "plant").mkdir()
    (tmp_path / "plant" / "a.py").write_text("x = 1\n")
    (tmp_path / "pyproject.toml").write_text("[project]\n")
    v1 = code_version(tmp_path, ("plant",))
    (tmp_path / "plant" / "a.py").write_text("x = 2\n")
    v2 = code_version(tmp_path, ("plant",))
    (tmp_path / "plant" / "b.py").write_text("")
    assert len({v1, v2, code_version(tmp_path, ("plant",))}) == 3
    assert code_version() == code_version()


def test_an_unreadable_cache_is_treated_as_empty_and_replaced(tmp_path):
    path = tmp_path / "cal.json"
    path.write_text("{not json")
    cache = CalibrationCache(path, now=Clock())
    assert cache.lookup("key") is None
    cache.remember_measured("key", _measured(), {})
    assert json.loads(path.read_text())["key"]["time_scale"] == 4.0


def test_the_cache_switched_off_measures_every_time_and_writes_nothing(tmp_path, monkeypatch):
    monkeypatch.setenv("SDVISC_CALIBRATION_CACHE", "none")
    monkeypatch.setenv("HOME", str(tmp_path))
    cache = CalibrationCache(now=Clock())
    assert cache.path is None
    calls = []
    for _ in range(2):
        cal = choose_time_scale(_run(), cache, lambda: calls.append(1) or _measured())
        assert "calibration cache off" in cal["line"]
    assert calls == [1, 1] and not list(tmp_path.rglob("*.json"))
    assert after_run(cal, "late", None) == {"held": False, "next_run_k": None}


@pytest.mark.parametrize("met", [True, False])
def test_the_reason_names_what_fell_short_and_what_was_chosen(met):
    cal = _measured()
    if not met:
        cal["trials"][-1] = _trial(4, False, ["SDC 70% busy (limit 50%)"])
        cal["met"] = False
    text = calibration_reason(cal)
    assert text.startswith("k = 2 fell short (SDC 60% busy")
    assert ("k = 4 held" in text) is met and ("fell short too" in text) is not met
