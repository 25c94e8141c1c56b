"""The os-ken shim takes one controller decision at a time.

os-ken's default hub is "native": the app's timer and its OpenFlow event handlers run in separate OS
threads. A tick that ran while a port-status handling was half done once saw a healed turbine
half-restored and declared a second ``no_path`` for it (CI, stop 24). This test runs the real app
class (no switches: its handler is called directly, as os-ken's event loop calls it) with its real
timer thread and checks that the controller is never entered by two threads at once.
"""

from __future__ import annotations

import threading
import time
from types import SimpleNamespace

import pytest

import sdn_app.app as app_module
from sdvisc.config import write_config
from tests.unit.test_sdn_logic import make_config


class Overlap:
    """Wraps the controller: every entry holds the GIL-free ``time.sleep`` for a moment, so two threads
    inside at once are all but certain to be seen where nothing keeps them apart."""

    def __init__(self, logic) -> None:
        self.logic = logic
        self.inside = 0
        self.most = 0
        self.calls = 0
        self.ticks = 0  # entries by the timer
        self.handled = 0  # entries by the port-status handler
        self.guard = threading.Lock()

    def _enter(self, fn, *args):
        with self.guard:
            self.inside += 1
            self.most = max(self.most, self.inside)
            self.calls += 1
        try:
            time.sleep(0.0005)
            return fn(*args)
        finally:
            with self.guard:
                self.inside -= 1

    def tick(self, now):
        with self.guard:
            self.ticks += 1
        return self._enter(self.logic.tick, now)

    def port_status(self, dpid, port, up, now):
        with self.guard:
            self.handled += 1
        return self._enter(self.logic.port_status, dpid, port, up, now)

    def __getattr__(self, name):
        return getattr(self.logic, name)


def running_app(cfg, tmp_path, monkeypatch):
    """The real app class on configuration ``cfg`` with its threads; stopped when the test ends."""
    monkeypatch.setenv(app_module.CONFIG_ENV, str(write_config(cfg, tmp_path / "sdn.json")))
    monkeypatch.setattr(app_module, "STOPPING", False)
    instance = app_module.SdviscApp()
    yield instance
    app_module.STOPPING = True
    for thread in (instance._timer, getattr(instance, "_intake_thread", None)):
        if thread is not None:
            thread.join(timeout=2.0)
    instance.stop()
    if instance._intake is not None:
        instance._intake.close()


@pytest.fixture
def app(tmp_path, monkeypatch):
    yield from running_app(make_config(state_dir=str(tmp_path)), tmp_path, monkeypatch)


def port_status_event(dpid: int, port: int, up: bool):
    ofp = SimpleNamespace(OFPPS_LINK_DOWN=1, OFPPC_PORT_DOWN=1, OFPPR_DELETE=1)
    desc = SimpleNamespace(port_no=port, state=0 if up else 1, config=0)
    return SimpleNamespace(msg=SimpleNamespace(datapath=SimpleNamespace(id=dpid, ofproto=ofp), desc=desc, reason=2))


def test_the_timer_and_a_handler_never_decide_at_once(app):
    """Port-status events handled in the test's thread while the app's timer ticks in its own:
    the controller is entered by one of them at a time."""
    watch = Overlap(app.logic)
    app.logic = watch
    st = app.logic.logic.state
    switch, port = next((n, p) for n, p in st.port_links if n in st.dpids)  # an OpenFlow switch's link port
    dpid = st.dpids[switch]
    # until both have run many times (not for a fixed second: on a loaded machine the timer thread can get
    # one tick in a second while this thread keeps the controller busy — a count of the machine, not of the
    # app); the deadline only bounds a broken timer
    deadline = time.monotonic() + 60.0
    up = False
    while time.monotonic() < deadline and not (watch.handled > 100 and watch.ticks > 10):
        app._port_status(port_status_event(dpid, port, up))
        up = not up
        if watch.handled % 50 == 0:
            time.sleep(0.001)  # let the timer's thread in now and then (the handlers of a real app are not back to back)
    assert watch.handled > 100 and watch.ticks > 10, (watch.handled, watch.ticks)  # both ran, each many times
    assert watch.most == 1, f"{watch.most} threads were inside the controller at once"

