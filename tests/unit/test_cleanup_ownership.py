"""The clean-up (host_tools/cleanup.py) stops what a run started and nothing else: a process only
with the run's marker in its environment, whatever its command line says (a deployed SDC, a user's
``tcpdump -r …/sdvisc-capture-….pcap``). Plain processes whose command line looks like a run's; no root."""

from __future__ import annotations

import os
import subprocess
import sys
import time

from host_tools.cleanup import RUN_MARKER, project_processes
from sdvisc.netns import command_line


def sleeper(module: str, marked: bool) -> subprocess.Popen:
    env = dict(os.environ)
    env.pop(RUN_MARKER.split("=")[0], None)
    if marked:
        env.update([RUN_MARKER.split("=")])
    # "-m <module>" appears in the command line as a service's does (python -c ignores what follows)
    proc = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)", "-m", module], env=env)
    # Popen returns once exec has begun; the new command line shows in /proc a moment later
    deadline = time.monotonic() + 10
    while module not in (command_line(proc.pid) or "") and time.monotonic() < deadline:
        time.sleep(0.01)
    return proc


def test_only_services_a_run_started_are_the_clean_ups():
    procs = {(module, marked): sleeper(module, marked)
             for module in ("owfcc.service", "sdc_unit.service", "plant.service") for marked in (False, True)}
    try:
        found = {pid for pid, _ in project_processes()}
        for (module, marked), proc in procs.items():
            assert (proc.pid in found) == marked, (module, marked)
    finally:
        for proc in procs.values():
            proc.kill()
            proc.wait(timeout=10)


def spawn(argv0: str, env: dict) -> subprocess.Popen:
    """``sleep 999`` with ``argv0`` as its argv[0] (the words a command line would show)."""
    proc = subprocess.Popen([argv0, "999"], executable="sleep", env=env)
    deadline = time.monotonic() + 10
    while argv0 not in (command_line(proc.pid) or "") and time.monotonic() < deadline:
        time.sleep(0.01)
    return proc


def test_a_process_that_names_a_runs_files_survives_a_clean_up_and_a_marked_child_does_not():
    """Issue 42 item 4: a user's ``sleep 999 sdvisc-capture-x.pcap mininet:x`` (as a ``tcpdump -r`` of
    a run's capture, an editor on it) is no run's; a process started while the run's marker is in
    the environment (mark_children: Mininet's shells, started by mnexec, inherit it) is."""
    from host_tools.cleanup import mark_children

    env = {k: v for k, v in os.environ.items() if k != RUN_MARKER.split("=")[0]}
    user = spawn("sleep 999 results/x/sdvisc-capture-x.pcap mininet:x", env)
    unmark = mark_children()
    try:
        shell = spawn("bash --norc -is mininet:h1", dict(os.environ))  # like a host shell the run started
    finally:
        unmark()
    assert RUN_MARKER.split("=")[0] not in os.environ  # taken out again
    later = spawn("bash --norc -is mininet:h2", dict(os.environ))  # started after the run: not marked
    try:  # (what the clean-up would stop; stopping it here could hit a run another process holds)
        found = {pid for pid, _ in project_processes()}
        assert shell.pid in found
        assert user.pid not in found and later.pid not in found
    finally:
        for proc in (user, shell, later):
            if proc.poll() is None:
                proc.kill()
            proc.wait(timeout=10)
