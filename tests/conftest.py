"""Shared test fixtures: paths, and the guard that network tests have what they need."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def network_ready() -> str | None:
    """None if Mininet + Open vSwitch tests can run here, else the reason."""
    if os.geteuid() != 0:
        return "needs root"
    if shutil.which("ovs-vsctl") is None or shutil.which("mnexec") is None:
        return "Open vSwitch / Mininet not installed (run ./testbed test, which installs them)"
    if subprocess.run(["ovs-vsctl", "--timeout=3", "show"], capture_output=True).returncode != 0:
        return "Open vSwitch daemons not running (./testbed test starts them)"
    return None


def pytest_configure(config):
    """Tests interrupt runs with SIGINT on purpose (Ctrl-C at a prompt, a killed process group). A
    shell that starts the suite as a background job without job control hands it an *ignored*
    SIGINT, which every child would inherit (ignored signals survive exec): give the children the
    default disposition back. A caught signal is reset to the default in an exec'd child."""
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


def pytest_collection_modifyitems(config, items):
    reason = network_ready()
    if reason is None:
        return
    skip = pytest.mark.skip(reason=f"network test: {reason}")
    for item in items:
        if "network" in item.keywords:
            item.add_marker(skip)


@pytest.fixture
def root() -> Path:
    return ROOT
