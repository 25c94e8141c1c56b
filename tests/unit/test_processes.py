"""The run's process supervisor without Mininet: real child processes that crash, are killed on
purpose, or take commands on stdin."""

from __future__ import annotations

import socket
import subprocess
import sys
import time

import pytest

from scenarios.processes import MAX_RESTARTS, Processes, RunError


def wait_exit(procs: Processes, name: str) -> None:
    end = time.time() + 10
    while procs.alive(name) and time.time() < end:
        time.sleep(0.02)


def test_a_crashing_service_is_restarted_a_bounded_number_of_times(tmp_path):
    events = []
    procs = Processes(tmp_path, events.append)
    procs.start("sdc1.sdc", [sys.executable, "-c", "import sys; print('up'); sys.exit(3)"])
    for k in range(MAX_RESTARTS + 2):
        wait_exit(procs, "sdc1.sdc")
        procs.supervise(float(k))
    assert len(procs.restarts["sdc1.sdc"]) == MAX_RESTARTS
    assert [e["type"] for e in events] == ["service_restarted"] * MAX_RESTARTS
    assert all(r["exit_code"] == 3 for r in procs.restarts["sdc1.sdc"])
    assert (tmp_path / "sdc1.sdc.log").read_text().count("up") == MAX_RESTARTS + 1  # the log is appended to


def test_a_planned_kill_is_not_restarted_and_a_crash_is(tmp_path):
    procs = Processes(tmp_path, lambda e: None)
    sleeper = [sys.executable, "-c", "import time; time.sleep(30)"]
    procs.start("sdc1.sdc", sleeper)
    procs.start("sdc2.sdc", sleeper)
    assert procs.kill("sdc1.sdc", crash=False) and procs.kill("sdc2.sdc", crash=True)
    wait_exit(procs, "sdc1.sdc")
    wait_exit(procs, "sdc2.sdc")
    procs.supervise(1.0)
    assert "sdc1.sdc" not in procs.restarts and len(procs.restarts["sdc2.sdc"]) == 1
    assert procs.alive("sdc2.sdc")
    procs.stop_all()
    assert not procs.alive("sdc2.sdc")


def test_no_controller_intervals_and_stdin_commands(tmp_path):
    events = []
    procs = Processes(tmp_path, events.append)
    cat = [sys.executable, "-c", "import sys\nfor line in sys.stdin: print('got', line.strip(), flush=True)"]
    procs.start("controller", cat, stdin=subprocess.PIPE)
    procs.supervise(0.5)
    assert procs.no_controller == []
    assert procs.send("controller", {"x": 1})
    end = time.time() + 10
    while '"x": 1' not in (tmp_path / "controller.log").read_text() and time.time() < end:
        time.sleep(0.02)
    procs.kill("controller", crash=False)
    wait_exit(procs, "controller")
    assert not procs.send("controller", {"x": 2})
    procs.supervise(1.0)
    procs.supervise(2.0)
    assert procs.no_controller == [[1.0, None]] and events[-1]["type"] == "no_controller"
    procs.stop_all()
    assert 'got {"x": 1}' in (tmp_path / "controller.log").read_text()


def test_a_controller_that_exits_when_asked_at_the_end_did_not_exit_early(tmp_path):
    procs = Processes(tmp_path, lambda e: None)
    sleeper = [sys.executable, "-c", "import time; time.sleep(30)"]
    procs.start("controller", sleeper)
    procs.start("sdc1.sdc", [sys.executable, "-c", "raise SystemExit(3)"])  # a crash before the end
    wait_exit(procs, "sdc1.sdc")
    procs.stop_controllers()  # the scenario's end: SIGTERM, the SDN app exits at once
    wait_exit(procs, "controller")
    procs.stop_all()
    assert procs.exited_early == {"sdc1.sdc": 3}


def test_wait_listening_returns_once_the_port_accepts_and_names_a_service_that_died(tmp_path):
    procs = Processes(tmp_path, lambda e: None)
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    listener = ("import socket, time; time.sleep(0.3); s = socket.socket(); "
                f"s.bind(('127.0.0.1', {port})); s.listen(); time.sleep(30)")
    procs.start("controller", [sys.executable, "-c", listener])
    try:
        procs.wait_listening("controller", port, "SDN app", timeout_s=30)  # listens only after 0.3 s
        with socket.create_connection(("127.0.0.1", port), timeout=5):
            pass
    finally:
        procs.kill("controller", crash=False)
    # a port of its own: the first listener, killed, may still accept on the old one for a moment (in a
    # full suite it once did, and the wait returned before it saw controller2's exit)
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port2 = probe.getsockname()[1]
    procs.start("controller2", [sys.executable, "-c", "import sys; sys.exit(4)"])
    with pytest.raises(RunError, match=r"SDN app exited with 4; see .*controller2\.log"):
        procs.wait_listening("controller2", port2, "SDN app", timeout_s=30)
