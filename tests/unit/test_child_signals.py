"""Issue 42 item 3 without a network: children start with default signal dispositions even when
this process ignores SIGHUP (nohup), and ending a process always ends (real processes)."""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
import time

from host_tools.child_signals import bound_node_stops, default_signals, end_group

SIGHUP_BIT = 1 << (signal.SIGHUP - 1)


def ignored_mask(status: str) -> int:
    return int(next(line for line in status.splitlines() if line.startswith("SigIgn:")).split()[1], 16)


def test_children_of_a_nohup_process_do_not_inherit_sighup_ignored():
    """The parent is started with SIGHUP ignored (as under nohup); after
    give_children_default_signals it still ignores SIGHUP, its exec'd children do not."""
    script = textwrap.dedent("""
        import os, signal, subprocess
        from host_tools.child_signals import give_children_default_signals
        before = subprocess.run(["cat", "/proc/self/status"], capture_output=True, text=True).stdout
        changed = give_children_default_signals()
        after = subprocess.run(["cat", "/proc/self/status"], capture_output=True, text=True).stdout
        os.kill(os.getpid(), signal.SIGHUP)  # this process goes on (it ignored SIGHUP, and still does)
        print(changed)
        print(before.split("SigIgn:")[1].split()[0], after.split("SigIgn:")[1].split()[0])
    """)
    res = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60,
                         preexec_fn=lambda: signal.signal(signal.SIGHUP, signal.SIG_IGN))
    assert res.returncode == 0, res.stderr
    changed, masks = res.stdout.splitlines()
    before, after = (int(m, 16) for m in masks.split())
    assert "SIGHUP" in changed
    assert before & SIGHUP_BIT and not after & SIGHUP_BIT


def test_default_signals_as_preexec_fn_undoes_an_inherited_ignore():
    res = subprocess.run(["cat", "/proc/self/status"], capture_output=True, text=True, timeout=30,
                         preexec_fn=lambda: (signal.signal(signal.SIGHUP, signal.SIG_IGN), default_signals()))
    assert not ignored_mask(res.stdout) & SIGHUP_BIT


def sleeper(traps: str) -> subprocess.Popen:
    proc = subprocess.Popen(["sh", "-c", f"trap '' {traps}; echo ready; exec sleep 60"] if traps else
                            ["sh", "-c", "echo ready; exec sleep 60"],
                            stdout=subprocess.PIPE, text=True, start_new_session=True)
    assert proc.stdout.readline().strip() == "ready"
    return proc


def test_end_group_escalates_to_sigterm_then_sigkill():
    plain, no_hup, stubborn = sleeper(""), sleeper("HUP"), sleeper("HUP TERM")
    try:
        assert end_group(plain, grace_s=0.3) == "SIGHUP"
        assert end_group(no_hup, grace_s=0.3) == "SIGTERM"  # sleep inherited SIGHUP ignored
        assert end_group(stubborn, grace_s=0.3) == "SIGKILL"
        assert stubborn.returncode == -signal.SIGKILL
        assert end_group(plain) is None  # already ended: nothing sent
    finally:
        for p in (plain, no_hup, stubborn):
            if p.poll() is None:
                p.kill()
                p.wait(timeout=5)


def test_a_node_whose_shell_ignores_sighup_is_stopped_despite_mininets_unbounded_wait():
    """Mininet's Node.terminate sends SIGHUP and then waits without a timeout; with the shell
    ignoring SIGHUP that wait never returned. bound_node_stops ends the shell first."""

    class Node:  # what Mininet's Node does on terminate, reduced to its waits
        privateDirs: list = []

        def __init__(self, shell):
            self.shell = shell

        def unmountPrivateDirs(self):  # noqa: N802 - Mininet's name
            pass

        def terminate(self):
            if self.shell.poll() is None:
                import os
                os.killpg(self.shell.pid, signal.SIGHUP)
            self.shell.wait()  # Mininet's Node.cleanup: no timeout

    class Net:
        def __init__(self, nodes):
            self.hosts, self.switches, self.controllers = nodes, [], []

    node = Node(sleeper("HUP"))
    try:
        bound_node_stops(Net([node]), grace_s=0.3)
        bound_node_stops(Net([node]), grace_s=0.3)  # twice: wrapped once
        node.terminate()
        assert node.shell.returncode == -signal.SIGTERM
    finally:
        if node.shell.poll() is None:
            node.shell.kill()
            node.shell.wait(timeout=5)


def test_a_signal_during_a_shielded_teardown_does_not_cut_it_short():
    import os

    from host_tools.child_signals import shield_signals

    before = signal.getsignal(signal.SIGINT)
    shielded = shield_signals()
    try:
        os.kill(os.getpid(), signal.SIGINT)  # would raise KeyboardInterrupt
        os.kill(os.getpid(), signal.SIGTERM)  # would end the process
        time.sleep(0.05)
    finally:
        for s, handler in shielded.items():
            signal.signal(s, handler)
    assert signal.getsignal(signal.SIGINT) is before
