"""Open vSwitch on a CPU of its own: the switch's threads on one CPU, every process of a run on the others.

Scenario key ``cpu_split`` (CLI ``--cpu-split on|off``). On the userspace datapath every packet of
every bridge goes through ovs-vswitchd's main thread; the plant, the SDC, the SDN app and the OWFCC
are the other busy processes. Left to the scheduler, all of them share both CPUs, so a packet waits
whenever the switch is queued behind an endpoint's time slice, and every process runs on caches the
others have just used. Split, the switch never waits for an endpoint and each side keeps its cache
(measured, docs/architecture.md "CPU split").

:func:`plan` chooses the CPUs (the highest allowed CPU for the switch, the rest for the run; nothing
with fewer than two). :func:`apply` pins every thread of every ovs-vswitchd process and of the calling
process (so every host shell and service the run starts afterwards inherits the endpoints' CPUs), puts
the switch's main thread at SCHED_FIFO (:data:`SWITCH_PRIORITY`) and writes what it changed to
:data:`MARKER` first; :func:`restore` puts everything back and removes the
marker. :func:`host_tools.cleanup.clean` calls :func:`restore` too, so a run that was killed leaves no
pinned switch behind once any later run or ``sdvisc clean`` starts.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

MARKER = Path("/run/sdvisc-cpu-split.json")
SWITCH_COMMS = ("ovs-vswitchd",)
SWITCH_PRIORITY = 5
"""SCHED_FIFO priority of ovs-vswitchd's main thread while the split is in place (below the plant's
and the SDC's 10, :func:`sdvisc.netns.raise_priority`; they run on the other CPUs). The main thread
forwards every packet of the userspace datapath's system ports; at SCHED_OTHER, any other busy
process on its CPU delays its wake-up by up to a scheduler tick (4 ms at CONFIG_HZ=250): all_visc_50's
answers at k = 8 then came ~4.4 ms late on the return path, every turbine at once
(benchmarks/switch_wake_latency.py: p99 35.7 ms at SCHED_OTHER, 0.11 ms at SCHED_FIFO beside a busy
process; benchmarks/measured/switch-wake-latency-2026-12-06.json). Its other threads (revalidators,
PMD threads that spin) keep their policy."""


def plan(allowed: set[int]) -> tuple[list[int], list[int]] | None:
    """(the switch's CPUs, the run's CPUs) for the ``allowed`` CPUs; None with fewer than two."""
    cpus = sorted(allowed)
    if len(cpus) < 2:
        return None
    return cpus[-1:], cpus[:-1]


def _threads(pid: int | str) -> list[int]:
    try:
        return [int(t) for t in os.listdir(f"/proc/{pid}/task")]
    except OSError:
        return []


def switch_processes() -> list[int]:
    """Process ids of ovs-vswitchd (and its ``--monitor`` parent)."""
    pids = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                comm = Path(f"/proc/{entry}/comm").read_text().strip()
            except OSError:
                continue
            if comm in SWITCH_COMMS:
                pids.append(int(entry))
    return pids


def _affinity(tid: int) -> list[int] | None:
    try:
        return sorted(os.sched_getaffinity(tid))
    except OSError:  # the thread ended
        return None


def _pin(tids: list[int], cpus) -> int:
    """Pin each thread of ``tids`` to ``cpus``; how many were pinned (threads may end meanwhile)."""
    done = 0
    for tid in tids:
        try:
            os.sched_setaffinity(tid, cpus)
            done += 1
        except OSError:
            pass
    return done


def apply() -> dict:
    """Split the CPUs (:func:`plan`); what was done, for summary.json. Undone by :func:`restore`."""
    restore()  # a split left by a run that was killed
    allowed = os.sched_getaffinity(0)
    split = plan(allowed)
    if split is None:
        return {"applied": False, "why": f"{len(allowed)} CPU allowed: nothing to split"}
    switch_cpus, run_cpus = split
    switch_threads = [t for pid in switch_processes() for t in _threads(pid)]
    if not switch_threads:
        return {"applied": False, "why": "no ovs-vswitchd process found"}
    own_threads = _threads("self")
    saved = {"switch": {str(t): _affinity(t) for t in switch_threads},
             "switch_default": sorted(allowed),
             "runner_pid": os.getpid(),
             "runner": {str(t): _affinity(t) for t in own_threads}}
    mains = [pid for pid in switch_processes() if len(_threads(pid)) > 1]  # the worker, not its --monitor
    saved["switch_policy"] = {str(t): _policy(t) for t in mains}
    MARKER.write_text(json.dumps(saved))
    pinned = _pin(switch_threads, switch_cpus)
    _pin(own_threads, run_cpus)
    fifo = _set_policy(mains, (os.SCHED_FIFO | os.SCHED_RESET_ON_FORK, SWITCH_PRIORITY))
    return {"applied": True, "switch_cpus": switch_cpus, "run_cpus": run_cpus, "switch_threads": pinned,
            "switch_main_thread": f"SCHED_FIFO:{SWITCH_PRIORITY}" if fifo else "unchanged (not permitted)"}


def _policy(tid: int) -> list[int] | None:
    try:
        return [os.sched_getscheduler(tid), os.sched_getparam(tid).sched_priority]
    except OSError:
        return None


def _set_policy(tids: list[int], policy) -> int:
    """Set each thread's (policy, priority); how many were set."""
    done = 0
    for tid in tids:
        try:
            os.sched_setscheduler(tid, policy[0], os.sched_param(policy[1]))
            done += 1
        except OSError:
            pass
    return done


def restore() -> bool:
    """Undo :func:`apply` (from :data:`MARKER`): every ovs-vswitchd thread back to the CPUs it had
    (threads started since: to all the CPUs it was allowed), the runner's threads likewise if the
    runner is this process. False if there was nothing to undo."""
    try:
        saved = json.loads(MARKER.read_text())
    except (OSError, ValueError):
        return False
    default = saved.get("switch_default") or sorted(os.sched_getaffinity(0))
    for tid, policy in (saved.get("switch_policy") or {}).items():
        _set_policy([int(tid)], policy or (os.SCHED_OTHER, 0))
    for pid in switch_processes():
        for tid in _threads(pid):
            _pin([tid], saved["switch"].get(str(tid)) or default)
    if saved.get("runner_pid") == os.getpid():
        for tid in _threads("self"):
            _pin([tid], saved["runner"].get(str(tid)) or default)
    MARKER.unlink(missing_ok=True)
    return True


def seen(pids: dict[str, int]) -> dict[str, list[int]]:
    """The CPUs each named process (and ovs-vswitchd, all its threads together) may run on now."""
    out = {name: _affinity(pid) for name, pid in pids.items()}
    switch = {c for pid in switch_processes() for t in _threads(pid) for c in (_affinity(t) or [])}
    return {**out, "ovs-vswitchd": sorted(switch)}


def pinned() -> bool:
    """True while a split is in place (:data:`MARKER` exists)."""
    return MARKER.exists()
