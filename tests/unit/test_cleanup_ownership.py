"""The clean-up (host_tools/cleanup.py) stops what a run started and nothing a lab deployed: a
deployable service (SDC, SDN app, OWFCC, card emulator) only with the run's marker in its
environment. Plain processes whose command line looks like a service; no root."""

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
            expected = marked or module == "plant.service"  # the plant simulator is never deployed
            assert (proc.pid in found) == expected, (module, marked)
    finally:
        for proc in procs.values():
            proc.kill()
            proc.wait()
