"""The CPU split on real Open vSwitch and Mininet (host_tools/cpu_split.py): during a run every service
may run only on the run's CPUs and every thread of ovs-vswitchd only on the switch's, its main thread at
SCHED_FIFO; after the run, and after a run that was killed (``sdvisc clean``), ovs-vswitchd may run
everywhere again, at the policy it had."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from host_tools import cpu_split
from tests.integration.helpers import ROOT, assert_no_leftovers, run_scenario, sdvisc

pytestmark = pytest.mark.network


def _switch_cpus() -> set[int]:
    return {c for pid in cpu_split.switch_processes() for t in os.listdir(f"/proc/{pid}/task")
            for c in os.sched_getaffinity(int(t))}


def _switch_policies() -> set[int]:
    """The scheduling policies of ovs-vswitchd's threads (the reset-on-fork flag left out)."""
    return {os.sched_getscheduler(int(t)) & ~os.SCHED_RESET_ON_FORK for pid in cpu_split.switch_processes()
            for t in os.listdir(f"/proc/{pid}/task")}


@pytest.mark.skipif(len(os.sched_getaffinity(0)) < 2, reason="one CPU: nothing to split")
def test_a_split_run_keeps_the_switch_and_the_services_apart_and_undoes_it(tmp_path):
    before, policies = _switch_cpus(), _switch_policies()
    s = run_scenario(ROOT / "scenarios" / "smoke.yaml", tmp_path, "--cpu-split", "on")
    split = s["cpu_split"]
    assert split["applied"], split
    assert split["switch_main_thread"] == f"SCHED_FIFO:{cpu_split.SWITCH_PRIORITY}", split
    seen = split["seen"]
    assert seen.pop("ovs-vswitchd") == split["switch_cpus"]
    assert {"plant", "sdc1.sdc", "controller", "owfcc.owfcc"} <= set(seen)
    assert all(cpus == split["run_cpus"] for cpus in seen.values()), seen
    assert s["turbines"]["wt1_1"]["packets"]["ctrl_rx"] > 0
    assert _switch_cpus() == before and _switch_policies() == policies
    assert_no_leftovers()


@pytest.mark.skipif(len(os.sched_getaffinity(0)) < 2, reason="one CPU: nothing to split")
def test_sdvisc_clean_unpins_the_switch_after_a_killed_run(tmp_path):
    before, policies = _switch_cpus(), _switch_policies()
    run = subprocess.Popen([sys.executable, "-m", "scenarios.cli", "run", str(ROOT / "scenarios" / "smoke.yaml"),
                            "--out", str(tmp_path), "--quiet", "--cpu-split", "on", "--duration", "30"],
                           cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        while not (tmp_path / "plant_ready.json").exists():
            assert run.poll() is None and time.monotonic() < deadline, "the run did not start"
            time.sleep(0.2)
        assert cpu_split.pinned() and len(_switch_cpus()) < len(before)
        assert os.SCHED_FIFO in _switch_policies()
    finally:
        os.killpg(run.pid, signal.SIGKILL)  # no teardown of its own
        run.wait()
    res = sdvisc("clean")
    assert res.returncode == 0, res.stderr
    assert "removed 1 cpu_split" in res.stdout
    assert _switch_cpus() == before and _switch_policies() == policies
    assert_no_leftovers()
