"""Issue 42 item 2: the command line's overrides go through the scenario's schema and checks, with
the file, before anything is built; a problem names the option (the file's own, file:line)."""

from __future__ import annotations

import pytest

import scenarios.runner
from scenarios import cli
from scenarios.loader import Override, ScenarioError, load_scenario
from tests.integration.helpers import ROOT

SC = ROOT / "scenarios"


@pytest.fixture
def ran(monkeypatch):
    """``sdvisc run`` with the network never built: the scenarios it would have run."""
    calls = []

    def fake_run(scenario, out, **kw):
        calls.append(scenario)
        raise scenarios.runner.RunError("not built in this test")

    monkeypatch.setattr(scenarios.runner, "run_scenario", fake_run)
    return calls


def run(capsys, *argv) -> tuple[int, str]:
    code = cli.main(["run", *argv, "--out", "/nonexistent/never-written"])
    return code, capsys.readouterr().err


def test_time_scale_auto_with_an_emulated_peer_is_refused_as_the_yaml_key_is(tmp_path, capsys, ran):
    code, err = run(capsys, str(SC / "external_peer.yaml"), "--time-scale", "auto")
    assert code == 1 and ran == [], "refused before anything was built"
    assert err.startswith("--time-scale auto: time_scale: ")
    yaml_key = tmp_path / "auto.yaml"
    yaml_key.write_text((SC / "external_peer.yaml").read_text().replace("time_scale: 4", "time_scale: auto"))
    with pytest.raises(ScenarioError) as from_file:
        load_scenario(yaml_key)
    reason = err.strip().split("time_scale: ", 1)[1]
    assert reason in str(from_file.value)  # the same check, the same words, from both places
    assert "Traceback" not in err


def test_a_duration_beyond_the_schema_is_refused_cleanly_before_building(capsys, ran):
    code, err = run(capsys, str(SC / "smoke.yaml"), "--duration", "1e9")
    assert code == 1 and ran == []
    assert err.strip() == "--duration 1e+09: duration_s: Input should be less than or equal to 3600"


def test_every_problem_at_once_options_by_name_the_file_by_line(tmp_path, capsys, ran):
    bad = tmp_path / "bad.yaml"
    bad.write_text((SC / "smoke.yaml").read_text() + "cpu_split: maybe\n")
    code, err = run(capsys, str(bad), "--time-scale", "nan", "--duration", "-1")
    assert code == 1 and ran == []
    lines = err.strip().splitlines()
    assert any(line.startswith("--time-scale nan: time_scale: must be a finite number") for line in lines)
    assert any(line.startswith("--duration -1: duration_s: Input should be greater than 0") for line in lines)
    n = len(bad.read_text().splitlines())
    assert any(line.startswith(f"{bad}:{n}: cpu_split:") for line in lines), lines


def test_a_shorter_duration_checks_the_timeline_against_it(capsys, ran):
    code, err = run(capsys, str(SC / "link_failure_dr.yaml"), "--duration", "1.5")
    assert code == 1 and ran == []
    assert "link_failure_dr.yaml:" in err and "t=2.0 s is after duration_s=1.5 (duration_s from --duration 1.5)" in err


def test_valid_overrides_reach_the_run(capsys, ran):
    code, _ = run(capsys, str(SC / "smoke.yaml"), "--time-scale", "4", "--duration", "2", "--pcap",
                  "--switch-links", "patch", "--cpu-split", "on")
    assert code == 2  # (the fake run's error)
    (sc,) = ran
    assert (sc.time_scale, sc.duration_s, sc.capture.pcap, sc.switch_links, sc.cpu_split) == (4.0, 2.0, True, "patch", True)


def test_duration_inf_is_open_ended_and_needs_cli(capsys, ran):
    code, err = run(capsys, str(SC / "smoke.yaml"), "--duration", "inf")
    assert code == 1 and ran == [] and "needs --cli" in err


def test_an_override_under_a_section_the_file_lacks():
    o = Override("--pcap", "", ("capture", "pcap"), True)
    data = {"name": "x"}
    o.apply(data)
    assert data == {"name": "x", "capture": {"pcap": True}}
    assert o.concerns(("capture", "pcap"), "x") and not o.concerns(("capture",), "x")
