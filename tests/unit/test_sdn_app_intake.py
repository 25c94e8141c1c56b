"""The os-ken shim's intake thread on a real UDP socket (loopback, no switches, no namespace): the
datagrams waiting at a wake-up become one decision, bad ones are counted, and a decision that raises
is counted and logged without ending the thread."""

from __future__ import annotations

import json
import os
import socket
import time

import pytest

from sdvisc import wire
from sdvisc.config import CONTROLLER_VMAC, AppConfig
from tests.unit.test_sdn_app_threads import running_app
from topologies import topos
from topologies.base import describe

SDC_IP = "127.0.0.21"  # sdc1 on loopback: any 127/8 address is this machine's
APP_IP = "127.0.0.1"


def heartbeat(seq: int) -> bytes:
    return wire.encode(wire.MsgType.HEARTBEAT, {"sdc_id": 1, "seq": seq, "n_instances": 0, "t_wall": 0.0},
                       header=wire.Header(seq, 0, 0))


@pytest.fixture
def app(tmp_path, monkeypatch):
    topo = topos["farm"](clusters=1, turbines=2, layout="compact")
    topo.add_intake(APP_IP, CONTROLLER_VMAC)
    desc = describe(topo)
    desc["hosts"]["sdc1"]["ip"] = SDC_IP
    cfg = AppConfig.model_validate({"topology": desc, "backup_sdc": None, "state_dir": str(tmp_path),
                                    "controller_vip": APP_IP, "intake_socket": {"netns_pid": None}})
    yield from running_app(cfg, tmp_path, monkeypatch)


def send(datagrams: list[tuple[str, bytes]]) -> None:
    for src, data in datagrams:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            sock.bind((src, 0))
            sock.sendto(data, (APP_IP, wire.PORT_CONTROLLER))


def wait_for(condition, timeout: float = 10.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.01)
    return condition()


def test_datagrams_on_the_socket_are_decided_and_bad_ones_counted(app):
    send([(SDC_IP, heartbeat(1)), (SDC_IP, heartbeat(2)), ("127.0.0.99", heartbeat(3)), (SDC_IP, b"\x00" * 9)])
    counters = app.logic.counters
    assert wait_for(lambda: counters["intake_rx"] == 4)
    assert counters["heartbeats"] == 2 and counters["drop_intake_unknown_source"] == 1
    assert counters["drop_malformed"] == 1 and counters["packet_in"] == 0
    assert app.intake_counts["rx"] == 4 and 1 <= app.intake_counts["wakeups"] <= 4


def test_a_decision_that_raises_is_counted_and_the_intake_goes_on(app, monkeypatch):
    delivered = app.logic.delivered
    calls = []

    def fails_once(batch, now):
        calls.append(len(batch))
        if len(calls) == 1:
            raise RuntimeError("a bug in a decision")
        return delivered(batch, now)

    monkeypatch.setattr(app.logic, "delivered", fails_once)
    send([(SDC_IP, heartbeat(1))])
    assert wait_for(lambda: app.intake_counts["decision_errors"] == 1)
    send([(SDC_IP, heartbeat(2))])
    assert wait_for(lambda: app.logic.counters["heartbeats"] == 1)
    assert app._intake_thread.is_alive()


def test_the_published_state_names_the_apps_threads_by_kernel_id(app):
    """benchmarks/sdn_app_threads.py reads each thread's CPU from /proc by these ids."""
    assert wait_for(lambda: {"intake", "timer"} <= set(app.thread_ids))
    pid = os.getpid()
    for tid in app.thread_ids.values():
        assert os.path.exists(f"/proc/{pid}/task/{tid}")  # a thread of this process
    assert app.thread_ids["intake"] != app.thread_ids["timer"]
    app._publish()
    state = app.state_dir / "sdn_state.json"
    assert wait_for(lambda: state.exists() and "threads" in json.loads(state.read_text() or "{}"))
    assert json.loads(state.read_text())["threads"] == app.thread_ids
