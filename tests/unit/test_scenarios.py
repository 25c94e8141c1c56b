"""Scenario schema and loader: every shipped scenario is valid; bad files name file, line and key."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

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
        ("timeline:\n  - {t: 9.0, do: visc_on, wt: wt1_1}\n", 1, "(top level)", "after duration_s"),
        ("step_s: -1\n", 4, "step_s", "greater than 0"),
        ("sdc: {method: magic}\n", 4, "sdc.method", "tustin"),
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
        "  - {t: 1.3, do: set, param: avr_ref, value: 1.04}\n"
        "  - {t: 1.4, do: load_step, mw: 50}\n"
        "  - {t: 1.5, do: fault, duration_s: 0.2}\n"
        "  - {t: 1.6, do: scr, value: 1.51}\n"
        "  - {t: 2.0, do: visc_off, wt: wt1_2}\n")))
    assert [e.do for e in sc.timeline] == ["visc_on", "link_down", "link_up", "kill", "set", "load_step",
                                           "fault", "scr", "visc_off"]
    assert sc.turbines_named() == ["wt1_2"]
    assert sc.timeline[0].params == {"h": 5.0, "m_q": 0.05}


def test_check_command_exit_codes(tmp_path):
    good = ROOT / "scenarios" / "smoke.yaml"
    ok = subprocess.run([sys.executable, "-m", "sdvisc.cli", "check", str(good)], capture_output=True, text=True)
    assert ok.returncode == 0, ok.stderr
    bad = write(tmp_path, BASE + "sdn: {dr_hold: 0.04}\n")
    res = subprocess.run([sys.executable, "-m", "sdvisc.cli", "check", str(bad)], capture_output=True, text=True)
    assert res.returncode == 1
    assert f"{bad}:4: sdn.dr_hold: unknown key" in res.stderr
