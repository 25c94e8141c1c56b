"""Scenario schema and loader: every shipped scenario is valid; bad files name file, line and key."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from plant import settable
from scenarios.loader import ScenarioError, load_scenario

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = sorted((ROOT / "scenarios").glob("*.yaml"))


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_shipped_scenarios_are_valid(path):
    sc = load_scenario(path)
    assert sc.duration_s > 0
    assert all(e.t <= sc.duration_s for e in sc.timeline)


def write(tmp_path, text: str) -> Path:
    path = tmp_path / "s.yaml"
    path.write_text(text)
    return path


BASE = "name: t\nduration_s: 3\ntopology: {name: paper, clusters: 1, turbines: 2}\n"


@pytest.mark.parametrize(
    ("body", "line", "key", "expect"),
    [
        ("plant:\n  model: minimal\n  colour: blue\n", 6, "plant.colour", "unknown key"),
        ("timeline:\n  - {t: 1.0, do: visc_on, wt: wt1_1, params: {h: fast}}\n", 5, "timeline.0.params.h", "number"),
        ("timeline:\n  - {t: 1.0, do: visc_on, wt: turbine1}\n", 5, "timeline.0.wt", "pattern"),
        ("timeline:\n  - {t: 1.0, do: visc_on, wt: wt7_1}\n", 5, "timeline.0.wt", "not in topology"),
        ("timeline:\n  - {t: 1.0, do: link_down, a: s1, b: s9}\n", 5, "timeline.0", "no link s1-s9"),
        ("timeline:\n  - {t: 9.0, do: visc_on, wt: wt1_1}\n", 5, "timeline.0.t", "after duration_s=3.0"),
        ("timeline:\n  - {t: 1.0, do: set, param: avr_reff, value: 1.0}\n", 5, "timeline.0.param",
         "no settable parameter 'avr_reff' (settable: grid_voltage, scr)"),
        ("timeline:\n  - {t: 1.0, do: load_step, mw: .nan}\n", 5, "timeline.0.mw", "must be a finite number"),
        ("duration_s: .inf\n", 2, "duration_s", "must be a finite number"),
        ("sdn: {visc_disabled: [wt9_9]}\n", 4, "sdn.visc_disabled.0", "not in topology"),
        ("step_s: -1\n", 4, "step_s", "greater than 0"),
        ("sdc: {method: magic}\n", 4, "sdc.method", "tustin"),
        ("sdn:\n  dr_hold_s: 2\n", 5, "sdn.dr_hold_s", "less than or equal to 1"),  # SdnOptions' bound
        ("owfcc: {retry_s: 0}\n", 4, "owfcc.retry_s", "greater than 0"),
    ],
)
def test_bad_scenario_names_line_key_and_expectation(tmp_path, body, line, key, expect):
    path = write(tmp_path, BASE + body)
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    text = str(err.value)
    assert text.startswith(f"{path}:{line}: {key}:"), text
    assert expect in text


def test_not_yaml_and_missing_file(tmp_path):
    with pytest.raises(ScenarioError, match=r"s.yaml:2: not valid YAML"):
        load_scenario(write(tmp_path, "name: [x\nduration_s: {\n"))
    with pytest.raises(ScenarioError, match="cannot read"):
        load_scenario(tmp_path / "absent.yaml")


def test_timeline_forms(tmp_path):
    sc = load_scenario(write(tmp_path, BASE + (
        "timeline:\n"
        "  - {t: 0.5, do: visc_on, wt: wt1_2, params: {h: 5, m_q: 0.05}}\n"
        "  - {t: 1.0, do: link_down, a: s1, b: s3}\n"
        "  - {t: 1.1, do: link_up, a: s1, b: s3}\n"
        "  - {t: 1.2, do: kill, host: sdc1, process: sdc}\n"
        "  - {t: 1.3, do: set, param: grid_voltage, value: 1.04}\n"
        "  - {t: 1.4, do: load_step, mw: 50}\n"
        "  - {t: 1.5, do: fault, duration_s: 0.2}\n"
        "  - {t: 1.6, do: scr, value: 1.51}\n"
        "  - {t: 2.0, do: visc_off, wt: wt1_2}\n")))
    assert [e.do for e in sc.timeline] == ["visc_on", "link_down", "link_up", "kill", "set", "load_step",
                                           "fault", "scr", "visc_off"]
    assert sc.turbines_named() == ["wt1_2"]
    assert sc.timeline[0].params == {"h": 5.0, "m_q": 0.05}


def test_all_errors_of_a_file_at_once(tmp_path):
    path = write(tmp_path, (
        "name: t\n"
        "duration_s: -1\n"
        "topology: {name: paper, clusters: 1, turbines: 2}\n"
        "timeline:\n"
        "  - {t: 0.5, do: visc_on, wt: wt7_1}\n"
        "  - {t: 0.6, do: link_down, a: s1, b: s9}\n"
        "  - {t: 0.7, do: load_step, mw: .nan}\n"
        "  - {t: 0.8, do: set, param: avr_reff, value: 1.0}\n"))
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    lines = str(err.value).splitlines()
    assert [line.split(": ", 2)[:2] for line in lines] == [
        [f"{path}:2", "duration_s"], [f"{path}:5", "timeline.0.wt"], [f"{path}:6", "timeline.1"],
        [f"{path}:7", "timeline.2.mw"], [f"{path}:8", "timeline.3.param"]], lines
    assert "greater than 0" in lines[0] and "not in topology" in lines[1] and "no link s1-s9" in lines[2]
    assert "must be a finite number" in lines[3] and "no settable parameter 'avr_reff'" in lines[4]


def test_cross_checks_with_valid_fields_and_bad_topology(tmp_path):
    # all fields valid: the timing and name checks are still reported together
    path = write(tmp_path, BASE + "timeline:\n  - {t: 9, do: visc_on, wt: wt1_1}\n  - {t: 1, do: kill, host: sdc9,"
                                  " process: sdc}\n")
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    assert [line.split(": ", 2)[1] for line in str(err.value).splitlines()] == ["timeline.0.t", "timeline.1.host"]
    # a bad topology section: names are checked against the default topology (paper, 5 x 2)
    path = write(tmp_path, "name: t\nduration_s: 3\ntopology: {clusters: 0}\n"
                           "timeline:\n  - {t: 1, do: visc_on, wt: wt5_2}\n  - {t: 1, do: visc_on, wt: wt6_1}\n")
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    lines = str(err.value).splitlines()
    assert [line.split(": ", 2)[1] for line in lines] == ["topology.clusters", "timeline.1.wt"], lines


@pytest.mark.parametrize("model", ["minimal", "full"])
def test_set_param_checked_against_the_plant_model(tmp_path, model):
    names = settable.settable_params(settable.model_class(model))
    head = BASE + f"plant: {{model: {model}}}\ntimeline:\n"
    sc = load_scenario(write(tmp_path, head + "".join(
        f"  - {{t: 1, do: set, param: {name}, value: 1.0}}\n" for name in names)))
    assert [e.param for e in sc.timeline] == names
    with pytest.raises(ScenarioError) as err:
        load_scenario(write(tmp_path, head + "  - {t: 1, do: set, param: mode, value: 1.0}\n"))
    assert f"{tmp_path}/s.yaml:6: timeline.0.param: plant model {model} has no settable parameter 'mode' " \
           f"(settable: {', '.join(names)})" == str(err.value)


def test_avr_ref_is_a_full_model_parameter(tmp_path):
    body = "timeline:\n  - {t: 1, do: set, param: avr_ref, value: 1.04}\n"
    assert load_scenario(write(tmp_path, BASE + "plant: {model: full}\n" + body)).timeline[0].value == 1.04
    with pytest.raises(ScenarioError, match="plant model minimal has no settable parameter 'avr_ref'"):
        load_scenario(write(tmp_path, BASE + body))


@pytest.mark.parametrize("text", [".nan", ".NaN", ".inf", "-.inf", "nan", "inf"])
@pytest.mark.parametrize("where", ["step_s: {}\n", "timeline:\n  - {{t: 1, do: set, param: scr, value: {}}}\n",
                                   "timeline:\n  - {{t: 1, do: visc_on, wt: wt1_1, params: {{h: {}}}}}\n"])
def test_non_finite_numbers_rejected(tmp_path, where, text):
    with pytest.raises(ScenarioError, match="must be a finite number"):
        load_scenario(write(tmp_path, BASE + where.format(text)))


def test_plant_action_the_model_cannot_apply(tmp_path, monkeypatch):
    class Bare:
        def set_scr(self, value: float) -> None: ...

    assert settable.supported_actions(Bare) == ["scr"]
    monkeypatch.setattr("scenarios.loader.model_class", lambda model: Bare)
    path = write(tmp_path, BASE + "timeline:\n  - {t: 1, do: load_step, mw: 5}\n  - {t: 1, do: fault, duration_s: 0.1}\n"
                                  "  - {t: 1, do: scr, value: 2}\n")
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    assert str(err.value).splitlines() == [f"{path}:5: timeline.0.do: plant model minimal cannot apply load_step",
                                           f"{path}:6: timeline.1.do: plant model minimal cannot apply fault"]


def test_settable_params_are_callable_on_built_models():
    """The names come from the classes; each must really be a one-number setter of a built model."""
    from plant.minimal import MinimalPlant
    from plant.sim import Plant

    built = {"minimal": MinimalPlant(2), "full": Plant(n_turbines=50, jit=False)}
    assert set(built) == set(settable.MODELS) - {"emt"}  # emt (DPsim): tests/unit/test_emt_service.py
    for model, plant in built.items():
        assert isinstance(plant, settable.model_class(model))
        names = settable.settable_params(type(plant))
        assert {"grid_voltage", "scr"} <= set(names)
        assert not {"mode", "visc_params", "battery", "power_ref"} & set(names)  # not one number
        assert settable.supported_actions(type(plant)) == ["load_step", "fault", "scr"]
        for name in names:
            getattr(plant, f"set_{name}")(1.0)
        plant.step()
        assert all(np.all(np.isfinite(v)) for v in plant.measurements().values()), model
    assert "avr_ref" in settable.settable_params(Plant)


def test_check_command_exit_codes(tmp_path):
    good = ROOT / "scenarios" / "smoke.yaml"
    ok = subprocess.run([sys.executable, "-m", "scenarios.cli", "check", str(good)], capture_output=True, text=True)
    assert ok.returncode == 0, ok.stderr
    bad = write(tmp_path, BASE + "sdn: {dr_hold: 0.04}\n")
    res = subprocess.run([sys.executable, "-m", "scenarios.cli", "check", str(bad)], capture_output=True, text=True)
    assert res.returncode == 1
    assert f"{bad}:4: sdn.dr_hold: unknown key" in res.stderr


# ---------------------------------------------------------------- the grid source, batteries, P*, relative set
FULL = BASE + "plant:\n  model: full\n"


def test_grid_battery_p_star_and_delta_keys(tmp_path):
    sc = load_scenario(write(tmp_path, FULL + (
        "  grid: {h: 5.0, s_mva: 1000, t_gov_s: 4}\n"
        "  batteries: {turbines: [wt1_1, wt1_2], soc_init: 0.6}\n"
        "  p_star: {wt1_1: 0.0}\n"
        "timeline:\n"
        "  - {t: 1, do: set, param: avr_ref, delta: 0.04}\n"
        "  - {t: 2, do: set, param: grid_emf, value: 0.92}\n")))
    assert sc.plant.grid.given() == {"h_grid": 5.0, "s_grid_mva": 1000.0, "t_gov": 4.0}
    assert sc.plant.batteries.turbines == ["wt1_1", "wt1_2"] and sc.plant.batteries.soc_init == 0.6
    assert sc.plant.p_star == {"wt1_1": 0.0}
    assert (sc.timeline[0].delta, sc.timeline[0].value) == (0.04, None)
    assert (sc.timeline[1].delta, sc.timeline[1].value) == (None, 0.92)
    assert "grid_voltage" in settable.relative_params(settable.model_class("minimal"))
    assert {"avr_ref", "grid_emf", "grid_voltage"} <= set(settable.relative_params(settable.model_class("full")))


@pytest.mark.parametrize(
    ("body", "line", "key", "expect"),
    [
        (FULL + "  grid: {h: -1}\n", 6, "plant.grid.h", "greater than or equal to 0"),
        (FULL + "  grid: {h: 5, inertia: 3}\n", 6, "plant.grid.inertia", "unknown key"),
        (FULL + "  grid: {s_mva: 0}\n", 6, "plant.grid.s_mva", "greater than 0"),
        (BASE + "plant:\n  grid: {h: 5}\n", 5, "plant.grid", "grid needs plant.model: full"),
        (BASE + "plant:\n  batteries: {turbines: [wt1_1]}\n", 5, "plant.batteries", "needs plant.model: full"),
        (FULL + "  batteries: {turbines: [wt1_1], soc_init: 0.95}\n", 6, "plant.batteries.soc_init",
         "less than or equal to 0.9"),
        (FULL + "  batteries: {turbines: []}\n", 6, "plant.batteries.turbines", "at least 1 item"),
        (FULL + "  batteries: {turbines: [wt1_1, wt1_1]}\n", 6, "plant.batteries.turbines", "more than once: wt1_1"),
        (FULL + "  batteries: {turbines: [wt1_1, wt9_1]}\n", 6, "plant.batteries.turbines.1",
         "turbine 'wt9_1' is not in topology"),
        (FULL + "  batteries: {turbines: [wt1_1], capacity_ah: 10}\n", 6, "plant.batteries.capacity_ah", "unknown key"),
        (FULL + "  p_star: {wt1_1: 2.0}\n", 6, "plant.p_star.wt1_1", "less than or equal to 1.1"),
        (FULL + "  p_star: {wt7_1: 0.0}\n", 6, "plant.p_star.wt7_1", "not in topology"),
        (FULL + "timeline:\n  - {t: 1, do: set, param: avr_ref, value: 1.0, delta: 0.04}\n", 7, "timeline.0",
         "exactly one of value (absolute) and delta (relative)"),
        (FULL + "timeline:\n  - {t: 1, do: set, param: avr_ref}\n", 7, "timeline.0", "exactly one of value"),
        (FULL + "timeline:\n  - {t: 1, do: set, param: sc_connected, delta: 1}\n", 7, "timeline.0.delta",
         "cannot change 'sc_connected' by a delta"),
    ],
)
def test_bad_grid_battery_and_delta_keys(tmp_path, body, line, key, expect):
    path = write(tmp_path, body)
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    text = str(err.value)
    assert text.startswith(f"{path}:{line}: {key}:"), text
    assert expect in text, text


def test_relative_set_reads_the_present_value():
    from plant.minimal import MinimalPlant
    from plant.service.model import apply_set
    from plant.sim import Plant

    plant = Plant(n_turbines=50, jit=False)
    ref0 = plant.get_avr_ref()
    assert apply_set(plant, {"param": "avr_ref", "delta": 0.04}) == {"before": ref0, "value": ref0 + 0.04}
    assert plant.sc.v_ref == pytest.approx(ref0 + 0.04)
    assert apply_set(plant, {"param": "avr_ref", "value": 1.0}) == {"value": 1.0} and plant.sc.v_ref == 1.0
    minimal = MinimalPlant(1)
    apply_set(minimal, {"param": "grid_voltage", "delta": -0.05})
    assert minimal.get_grid_voltage() == pytest.approx(0.95)
    with pytest.raises(ValueError, match="by a delta"):
        apply_set(minimal, {"param": "scr", "delta": 1.0})
