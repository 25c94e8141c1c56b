"""The CPU split's plan (host_tools/cpu_split.py): which CPUs Open vSwitch gets and which the run."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from host_tools.cpu_split import plan


def test_two_cpus_give_the_switch_the_second_and_the_run_the_first():
    assert plan({0, 1}) == ([1], [0])


def test_one_cpu_is_not_split():
    assert plan({3}) is None


def test_the_switch_gets_the_highest_allowed_cpu_even_with_gaps():
    assert plan({5, 0, 2}) == ([5], [0, 2])


@given(st.sets(st.integers(0, 255), min_size=2, max_size=64))
def test_every_allowed_cpu_goes_to_exactly_one_side(allowed):
    switch, run = plan(allowed)
    assert set(switch) | set(run) == allowed and not set(switch) & set(run)
    assert switch and run


def test_the_switch_main_thread_runs_at_fifo_while_split_and_gets_its_policy_back(tmp_path, monkeypatch):
    import os

    import host_tools.cpu_split as split

    threads = {100: [100, 101, 102], 99: [99]}  # ovs-vswitchd (main thread 100) and its --monitor parent 99
    policy = {t: (os.SCHED_OTHER, 0) for ts in threads.values() for t in ts}
    policy[555] = (os.SCHED_OTHER, 0)
    monkeypatch.setattr(split, "MARKER", tmp_path / "split.json")
    monkeypatch.setattr(split, "switch_processes", lambda: [99, 100])
    monkeypatch.setattr(split, "_threads", lambda pid: [555] if pid == "self" else threads[pid])
    monkeypatch.setattr(os, "sched_getaffinity", lambda tid: {0, 1})
    monkeypatch.setattr(os, "sched_setaffinity", lambda tid, cpus: None)
    monkeypatch.setattr(os, "sched_getscheduler", lambda tid: policy[tid][0])
    monkeypatch.setattr(os, "sched_getparam", lambda tid: os.sched_param(policy[tid][1]))
    monkeypatch.setattr(os, "sched_setscheduler", lambda tid, p, param: policy.__setitem__(tid, (p, param.sched_priority)))

    done = split.apply()
    assert done["switch_main_thread"] == f"SCHED_FIFO:{split.SWITCH_PRIORITY}"
    assert policy[100] == (os.SCHED_FIFO | os.SCHED_RESET_ON_FORK, split.SWITCH_PRIORITY)  # the worker's main thread
    # its other threads (revalidators, PMDs that spin), the --monitor parent, the runner: as they were
    assert policy[101] == policy[102] == policy[99] == policy[555] == (os.SCHED_OTHER, 0)
    assert split.restore()
    assert all(p == (os.SCHED_OTHER, 0) for p in policy.values())
    assert not split.MARKER.exists()
