"""The SDC unit, the SDN app and the OWFCC started from one configuration file outside Mininet
(issue 29, item 3; docs/real-devices.md): YAML configurations with every problem named by key and
line, the ``sdvisc sdc | sdn-app | owfcc | gtnet-card | owfcc-send`` subcommands, the OWFCC's
schedule and command socket, SIGTERM writing each service's files, and the shipped examples
(docs/deploy/) valid against their models. Loopback only, no root; no timing is asserted."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path
from types import SimpleNamespace

import pytest
import yaml

from owfcc.service import Owfcc
from scenarios import cli_services, configs
from scenarios.cli import main as sdvisc_main
from scenarios.loader import load_scenario
from sdvisc import wire
from sdvisc.config import (
    AppConfig,
    ConfigError,
    OwfccConfig,
    PlantOptions,
    SdcConfig,
    load_config,
    write_config,
)
from tests.unit.test_sdc_service_udp import _request

ROOT = Path(__file__).resolve().parents[2]
DEPLOY = ROOT / "docs" / "deploy"
EXAMPLES = {"sdc1.yaml": SdcConfig, "sdn-app.yaml": AppConfig, "owfcc.yaml": OwfccConfig}
WAIT_S = 120.0  # upper bound for a service to come up on a busy 2-core machine (the SDC may compile its step)


# ------------------------------------------------------------------ configuration files

def test_every_example_config_validates_against_its_model(tmp_path):
    assert {p.name for p in DEPLOY.glob("*.yaml")} == set(EXAMPLES), "an example config without its model here"
    for name, model in EXAMPLES.items():
        cfg = load_config(model, DEPLOY / name)
        # the same model read back from JSON (what the runner writes)
        assert load_config(model, write_config(cfg, tmp_path / f"{name}.json")) == cfg
    owfcc = load_config(OwfccConfig, DEPLOY / "owfcc.yaml")
    assert owfcc.schedule and not owfcc.stdin_commands and owfcc.command_socket
    app = load_config(AppConfig, DEPLOY / "sdn-app.yaml")
    assert [h.switch for h in app.topology.hosts.values()] and len(app.topology.switches) == 2


def test_yaml_and_json_load_to_the_same_model(tmp_path):
    data = {"sdc_id": 2, "role": "backup", "step_s": 0.00067, "out_dir": "/var/lib/sdvisc/sdc2",
            "bind_ip": "127.0.0.1", "realtime_priority": False, "gather_steps": 0.25}
    (tmp_path / "sdc.json").write_text(json.dumps(data))
    (tmp_path / "sdc.yaml").write_text(yaml.safe_dump(data))
    (tmp_path / "sdc.yml").write_text(yaml.safe_dump(data))
    json_cfg, yaml_cfg, yml_cfg = (load_config(SdcConfig, tmp_path / f) for f in ("sdc.json", "sdc.yaml", "sdc.yml"))
    assert json_cfg == yaml_cfg == yml_cfg and yaml_cfg.role == "backup" and yaml_cfg.gather_steps == 0.25


BAD_OWFCC = """\
out_dir: /tmp/x
retry_s: -1
schedule:
  - {t_s: 1.0, cmd: visc_on, wt: wt1_1}
  - t_s: 2.0
    cmd: visc_of
    wt: wt1_2
comand_socket: /run/sdvisc/owfcc.sock
"""


def test_a_yaml_with_three_mistakes_names_all_three_with_keys_and_lines(tmp_path):
    path = tmp_path / "owfcc.yaml"
    path.write_text(BAD_OWFCC)
    with pytest.raises(ConfigError) as err:
        load_config(OwfccConfig, path)
    lines = str(err.value).splitlines()
    assert len(lines) == 3, lines
    assert lines[0].startswith(f"{path}:2: retry_s: ")
    assert lines[1].startswith(f"{path}:6: schedule.1.cmd: ")
    assert lines[2] == f"{path}:8: comand_socket: unknown key (not allowed here)"


def test_a_yaml_that_does_not_parse_names_its_line(tmp_path):
    path = tmp_path / "sdc.yaml"
    path.write_text("out_dir: /tmp/x\nstep_s: [0.00067\nsdc_id: 1\n")
    with pytest.raises(ConfigError, match=rf"^{path}:\d+: not valid YAML"):
        load_config(SdcConfig, path)


def test_a_json_config_is_read_as_before(tmp_path):
    path = tmp_path / "sdc.json"
    path.write_text(json.dumps({"out_dir": ".", "role": "boss", "step_s": -1}))
    with pytest.raises(ConfigError) as err:
        load_config(SdcConfig, path)
    assert f"{path}: role: " in str(err.value) and f"{path}: step_s: " in str(err.value)  # no line numbers


def test_the_runner_leaves_the_deployment_options_at_their_defaults(tmp_path):
    sc = load_scenario(ROOT / "scenarios" / "default.yaml")
    cfg = configs.owfcc_config(sc, str(tmp_path))
    assert (cfg.stdin_commands, cfg.schedule, cfg.command_socket, cfg.bind_ip) == (True, [], None, "0.0.0.0")


# ------------------------------------------------------------------ the subcommands, without starting anything

def test_sdvisc_sdc_with_a_bad_config_exits_2_naming_the_key(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(cli_services, "become", lambda *a: pytest.fail("started despite a bad config"))
    bad = tmp_path / "bad.yaml"
    bad.write_text("sdc_id: 1\nout_dir: /tmp/x\nstep_s: 0.00067\ncapcity: 8\n")
    assert sdvisc_main(["sdc", "--config", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("sdvisc sdc: ") and f"{bad}:4: capcity: unknown key" in err


def test_sdvisc_gtnet_card_refuses_a_bad_config_or_a_missing_emulator(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(cli_services, "become", lambda *a: pytest.fail("started despite a bad config"))
    bad = tmp_path / "card.yaml"
    bad.write_text("colour: red\n")
    assert sdvisc_main(["gtnet-card", "--config", str(bad)]) == 2
    assert capsys.readouterr().err.startswith("sdvisc gtnet-card: ")


def test_a_service_becomes_python_m_module_with_its_log(tmp_path, monkeypatch):
    became = []
    monkeypatch.setattr(cli_services, "become", lambda argv, env, log_fd: became.append((argv, env, log_fd)) or 0)
    cfg = tmp_path / "app.yaml"
    app = yaml.safe_load((DEPLOY / "sdn-app.yaml").read_text())
    cfg.write_text(yaml.safe_dump(dict(app, state_dir=str(tmp_path / "state"))))
    assert sdvisc_main(["sdn-app", "--config", str(cfg), "--ofp-port", "16653"]) == 0
    argv, env, log_fd = became[0]
    os.close(log_fd)
    assert argv == [sys.executable, "-m", "sdn_app", "--config", str(cfg.resolve()), "--ofp-port", "16653",
                    "--listen-host", "0.0.0.0"]
    assert str(ROOT) in env["PYTHONPATH"].split(os.pathsep) and env["PYTHONUNBUFFERED"] == "1"
    log = (tmp_path / "state" / "sdn-app.log").read_text()
    assert log.startswith("sdvisc sdn-app: ") and "-m sdn_app" in log


# ------------------------------------------------------------------ the OWFCC's schedule and command socket

def _udp(host: str = "127.0.0.1", port: int = 0) -> socket.socket:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind((host, port))
    return sock


def _events(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines()] if path.exists() else []


def _until(condition, what: str, timeout_s: float = WAIT_S):
    deadline = time.time() + timeout_s
    while time.time() < deadline:
        result = condition()
        if result:
            return result
        time.sleep(0.02)
    pytest.fail(f"no {what} within {timeout_s:g} s")


def _fake_controller(sock: socket.socket, got: list, stop: threading.Event) -> None:
    """Answer every REQUEST with REPLY OK (what the SDN app does when a path is installed)."""
    sock.settimeout(0.05)
    while not stop.is_set():
        try:
            data, addr = sock.recvfrom(2048)
        except TimeoutError:
            continue
        msg = wire.decode(data, header=True)
        got.append(msg)
        sock.sendto(wire.encode(wire.MsgType.REPLY, {"req_id": msg["req_id"], "status": int(wire.Status.OK),
                                                     "wt": msg["wt"], "cmd": msg["cmd"], "detail": 0},
                                header=wire.Header(msg["req_id"], 0, 0)), addr)


def test_the_owfcc_sends_its_schedule_and_the_command_socket_s_commands(tmp_path, capsys):
    controller, own = _udp(), _udp()
    own.setblocking(False)
    cfg = OwfccConfig(out_dir=str(tmp_path), controller_vip="127.0.0.1", stdin_commands=False, time_scale=4.0,
                      command_socket=str(tmp_path / "owfcc.sock"),
                      schedule=[{"t_s": 0.1, "cmd": "set_params", "wt": "wt1_1", "params": {"v_ref": 1.02}},
                                {"t_s": 0.0, "cmd": "visc_on", "wt": "wt1_1", "params": {"h": 3.0}}])
    owfcc = Owfcc(cfg, sock=own, controller=controller.getsockname())
    got, stop = [], threading.Event()
    answering = threading.Thread(target=_fake_controller, args=(controller, got, stop), daemon=True)
    answering.start()
    running = threading.Thread(target=owfcc.run, daemon=True)
    running.start()
    try:
        _until(lambda: len(got) >= 2, "scheduled requests")
        args = SimpleNamespace(socket=cfg.command_socket, timeout=10.0,
                               commands=['{"cmd": "visc_off", "wt": "wt1_2"}', '{"cmd": "visc_on", "wt": "wt1_2", '
                                         '"params": {"inertia": 3}}'])
        assert cli_services.owfcc_send(args) == 1  # the second one is refused: an unknown parameter
        answers = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
        assert answers[0] == {"req_id": 3} and "inertia" in answers[1]["error"]
        _until(lambda: len(got) >= 3 and not owfcc.pending, "the socket's request answered")
    finally:
        owfcc.stop()
        running.join(timeout=10.0)
        stop.set()
        answering.join(timeout=2.0)
        owfcc.close()
        controller.close()
    assert not running.is_alive() and not Path(cfg.command_socket).exists()
    assert [(m["cmd"], m["wt"]) for m in got[:3]] == [
        (wire.Command.VISC_ON, 101), (wire.Command.SET_PARAMS, 101), (wire.Command.VISC_OFF, 102)]
    assert got[1]["mask"] == wire.ParamMask.V_REF and got[1]["v_ref"] == pytest.approx(1.02)
    requests = [e for e in _events(tmp_path / "owfcc_events.jsonl") if e["type"] == "owfcc_request"]
    assert [e.get("source") for e in requests] == ["schedule", "schedule", "socket"]
    assert all(e["t_run"] >= e["t_s"] for e in requests[:2])  # never before its time
    assert owfcc.stats()["replies_rx"] == 3


def _start(args: list[str], tmp_path: Path) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p))
    return subprocess.Popen([sys.executable, "-m", "scenarios.cli", *args], cwd=tmp_path, env=env,
                            stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)


def _stop(proc: subprocess.Popen) -> int:
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
    try:
        return proc.wait(timeout=30.0)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
        pytest.fail("did not stop within 30 s of SIGTERM")


def _skip_if_port_busy(proc: subprocess.Popen, log: Path) -> None:
    if proc.poll() is not None and log.exists() and "Address already in use" in log.read_text():
        pytest.skip(f"a port of the service is busy on the loopback: {log.read_text()[-300:]}")


def test_sdvisc_owfcc_runs_without_stdin_and_writes_its_stats_on_sigterm(tmp_path):
    cfg = tmp_path / "owfcc.yaml"
    cfg.write_text(yaml.safe_dump({
        "out_dir": str(tmp_path / "out"), "controller_vip": "127.0.0.1", "bind_ip": "127.0.0.1",
        "stdin_commands": False, "command_socket": str(tmp_path / "owfcc.sock"), "max_tries": 1,
        "schedule": [{"t_s": 0.0, "cmd": "visc_on", "wt": "wt1_1"}]}))
    proc = _start(["owfcc", "--config", str(cfg)], tmp_path)
    log = tmp_path / "out" / "owfcc.log"
    try:
        events = tmp_path / "out" / "owfcc_events.jsonl"
        _until(lambda: _events(events) or proc.poll() is not None, "scheduled request")
        _skip_if_port_busy(proc, log)
        assert proc.poll() is None, log.read_text()  # stdin (here /dev/null) ended: it goes on
        sent = subprocess.run([sys.executable, "-m", "scenarios.cli", "owfcc-send", "--socket",
                               str(tmp_path / "owfcc.sock"), '{"cmd": "visc_off", "wt": "wt1_1"}'],
                              cwd=ROOT, capture_output=True, text=True, timeout=WAIT_S)
        assert sent.returncode == 0 and json.loads(sent.stdout) == {"req_id": 2}, sent.stderr
    finally:
        code = _stop(proc)
    assert code == 0, log.read_text()
    stats = json.loads((tmp_path / "out" / "owfcc_stats.json").read_text())
    assert stats["requests"] == 2
    assert log.read_text().startswith("sdvisc owfcc: ")


# ------------------------------------------------------------------ the SDC and the SDN app as processes

def test_sdvisc_sdc_answers_its_controller_and_writes_its_stats_on_sigterm(tmp_path):
    try:
        controller = _udp("127.0.0.1", wire.PORT_CONTROLLER)
    except OSError as exc:
        pytest.skip(f"the controller port is busy on the loopback: {exc}")
    controller.settimeout(0.2)
    cfg = tmp_path / "sdc1.yaml"
    cfg.write_text(yaml.safe_dump({
        "sdc_id": 1, "step_s": 0.00067, "out_dir": str(tmp_path / "out"), "bind_ip": "127.0.0.1",
        "controller_vip": "127.0.0.1", "realtime_priority": False, "capacity": 4}))
    proc = _start(["sdc", "--config", str(cfg)], tmp_path)
    log = tmp_path / "out" / "sdc1.log"
    try:
        _until(lambda: (tmp_path / "out" / "sdc1_ready.json").exists() or proc.poll() is not None, "ready file")
        _skip_if_port_busy(proc, log)
        assert proc.poll() is None, log.read_text()
        controller.sendto(_request(wire.Command.START_INSTANCE, 101, 7), ("127.0.0.1", wire.PORT_SDC))

        def reply():
            try:
                msg = wire.decode(controller.recvfrom(2048)[0], header=True)
            except TimeoutError:
                return None
            return msg if msg.type == wire.MsgType.REPLY else None  # (heartbeats come too)
        answer = _until(reply, "REPLY to START_INSTANCE", 30.0)
    finally:
        code = _stop(proc)
        controller.close()
    assert (answer["req_id"], answer["status"], answer["wt"]) == (7, wire.Status.OK, 101)
    assert code == 0, log.read_text()
    stats = json.loads((tmp_path / "out" / "sdc1_stats.json").read_text())
    assert stats and log.read_text().startswith("sdvisc sdc: ")


def test_sdvisc_sdn_app_writes_its_state_and_events_and_stops_on_sigterm(tmp_path):
    app = yaml.safe_load((DEPLOY / "sdn-app.yaml").read_text())
    cfg = tmp_path / "sdn-app.yaml"
    cfg.write_text(yaml.safe_dump(dict(app, state_dir=str(tmp_path / "state"))))
    with socket.socket() as probe:  # a free TCP port for OpenFlow
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    proc = _start(["sdn-app", "--config", str(cfg), "--ofp-port", str(port), "--listen-host", "127.0.0.1"], tmp_path)
    state = tmp_path / "state" / "sdn_state.json"
    try:
        _until(lambda: state.exists() or proc.poll() is not None, "sdn_state.json")
        assert proc.poll() is None, (tmp_path / "state" / "sdn-app.log").read_text()
    finally:
        code = _stop(proc)
    assert code == 0
    final = json.loads(state.read_text())
    assert set(final["tables"]["T1"]) == {"wt1_1", "wt1_2"}
    assert state.read_text().startswith("{\n")  # the final, indented state (written at SIGTERM)
    assert [e["type"] for e in _events(tmp_path / "state" / "sdn_events.jsonl")][:1] == ["app_start"]


@pytest.mark.parametrize("after_log_line", ["loading app sdn_app.app", "instantiating app sdn_app.app"])
def test_sdvisc_sdn_app_ends_on_a_sigterm_that_comes_while_it_is_still_starting(tmp_path, after_log_line):
    """A SIGTERM while os-ken is still loading or instantiating the apps (a loaded machine, a run
    stopped at once) ended outside the launcher's join, and os-ken's blocked threads kept the
    interpreter alive until the SIGKILL (seen 2 in 15 under two CPU hogs): it must end by itself."""
    app = yaml.safe_load((DEPLOY / "sdn-app.yaml").read_text())
    cfg = tmp_path / "sdn-app.yaml"
    cfg.write_text(yaml.safe_dump(dict(app, state_dir=str(tmp_path / "state"))))
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    proc = _start(["sdn-app", "--config", str(cfg), "--ofp-port", str(port), "--listen-host", "127.0.0.1"], tmp_path)
    log = tmp_path / "state" / "sdn-app.log"
    _until(lambda: (log.exists() and after_log_line in log.read_text()) or proc.poll() is not None, after_log_line)
    assert _stop(proc) in (0, -signal.SIGTERM)  # (-SIGTERM: it came before the handler was in place)


# ------------------------------------------------------------------ docs/real-devices.md against the code

def points_table(mtype: wire.MsgType) -> str:
    """The GTNET-SKT points of one message as docs/real-devices.md lists them, from LAYOUTS."""
    rows = ["| Word | Point | Type | Unit | Meaning |", "|---:|---|---|---|---|"]
    rows += [f"| {i} | `{f.name}` | {'int' if f.kind == 'i32' else 'float'} | {f.unit or '—'} | {f.doc} |"
             for i, f in enumerate(wire.LAYOUTS[mtype])]
    return "\n".join(rows)


def test_the_rtds_checklist_matches_the_layouts_ports_and_rates():
    doc = (ROOT / "docs" / "real-devices.md").read_text()
    for mtype in (wire.MsgType.MEAS, wire.MsgType.AK, wire.MsgType.CTRL, wire.MsgType.REQUEST):
        assert points_table(mtype) in doc, f"the {mtype.name} points differ from sdvisc/wire_layouts.py LAYOUTS"
    for name in ("PORT_TURBINE", "PORT_SDC", "PORT_CONTROLLER", "PORT_OWFCC"):
        assert f"`{name}` {getattr(wire, name)}" in doc
    step_s = SdcConfig.model_fields["step_s"].default
    assert step_s == 0.67e-3 and f"**{round(1 / step_s)} datagrams/s per turbine in each direction**" in doc
    for mtype, per_s in ((wire.MsgType.MEAS, 1 / step_s), (wire.MsgType.CTRL, 1 / step_s),
                          (wire.MsgType.AK, 1 / PlantOptions.model_fields["ak_period_s"].default)):
        words = [wire.word_count(mtype, header=h) for h in (False, True)]
        row = (f"| {words[0]} / {words[1]} | {round(per_s * 4 * words[0])} / {round(per_s * 4 * words[1])} | "
               f"{round(per_s * (4 * words[0] + 28))} / {round(per_s * (4 * words[1] + 28))} |")
        assert row in doc, f"{mtype.name}: {row}"
    for section in ("## External switches", "## External plant in a scenario", "## Limits"):
        assert section in doc


def test_sdvisc_gtnet_card_runs_the_project_s_card_emulator(tmp_path):
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:  # a free UDP port for the one turbine
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    cfg = tmp_path / "card.yaml"
    cfg.write_text(yaml.safe_dump({
        "step_s": 0.00067, "time_scale": 4.0, "bind_ip": "127.0.0.1", "controller_vip": "127.0.0.1",
        "controller_port": port, "out_dir": str(tmp_path / "out"),
        "turbines": [{"name": "wt1_1", "wid": 101, "port": port}]}))  # (no stream: nothing is sent)
    proc = _start(["gtnet-card", "--config", str(cfg)], tmp_path)
    log = tmp_path / "out" / "gtnet-card.log"
    try:
        _until(lambda: (tmp_path / "out" / "gtnet_card_ready.json").exists() or proc.poll() is not None, "ready file")
        _skip_if_port_busy(proc, log)
        assert proc.poll() is None, log.read_text()
    finally:
        code = _stop(proc)
    assert code == 0, log.read_text()
    assert (tmp_path / "out" / "gtnet_card_stats.json").exists() and log.read_text().startswith("sdvisc gtnet-card: ")
