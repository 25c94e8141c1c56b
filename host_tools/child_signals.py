"""Children that start with default signal dispositions, and stops that always end (issue 42 item 3).

An *ignored* signal stays ignored across ``exec``: under ``nohup`` (some CI runners and service
managers do the same) every process a run starts inherits SIG_IGN for SIGHUP. Mininet ends a
node's shell with SIGHUP only and then waits for it without a timeout, so an ssh client (a server
node's shell, topologies/cluster.py) that ignores SIGHUP made ``ClusterNet.stop()`` wait forever.

* :func:`give_children_default_signals` (at a run's start, main thread): each of :data:`SIGNALS`
  this process ignores gets a handler that does nothing instead — this process still ignores it,
  but a *caught* signal is reset to the default in an exec'd child, whoever starts the child
  (Mininet, subprocess, tcpdump's wrapper);
* :func:`default_signals` is a ``preexec_fn`` that does the same in the child itself (and
  unblocks every signal), for the children whose ``Popen`` we control;
* :func:`end_group` ends a process (group): SIGHUP (what Mininet sends a shell), SIGTERM after
  :data:`GRACE_S`, SIGKILL after another :data:`GRACE_S`, then a last bounded wait —
  :func:`bound_node_stops` puts it in front of every Mininet node's ``terminate`` so Mininet's
  own unbounded ``wait`` finds the shell already gone.
"""

from __future__ import annotations

import os
import signal
import subprocess
import threading

SIGNALS = (signal.SIGHUP, signal.SIGINT, signal.SIGQUIT, signal.SIGTERM)
"""The signals a child must not inherit as ignored (the ones used to stop things)."""
GRACE_S = 2.0
"""How long a process is given after each of SIGHUP and SIGTERM before the next signal."""
LAST_WAIT_S = 5.0
"""After SIGKILL: how long to wait for the kernel to reap it (a process in D state may take longer:
it is then left, and reported by ``sdvisc clean``)."""


def _still_ignored(signum, frame) -> None:  # noqa: ARG001 - a signal handler's signature
    """This process goes on ignoring the signal (as it did); its exec'd children do not."""


def give_children_default_signals() -> list[str]:
    """Replace SIG_IGN by :func:`_still_ignored` for :data:`SIGNALS`; the names changed. Only the
    main thread can set handlers; elsewhere nothing changes (use :func:`default_signals`)."""
    if threading.current_thread() is not threading.main_thread():
        return []
    changed = []
    for sig in SIGNALS:
        if signal.getsignal(sig) is signal.SIG_IGN:
            signal.signal(sig, _still_ignored)
            changed.append(sig.name)
    return changed


def shield_signals() -> dict:
    """While a teardown runs: SIGINT, SIGTERM and SIGHUP do nothing (a second Ctrl-C raised
    KeyboardInterrupt inside ``net.stop()`` and left the bridges; the teardown is bounded, so
    nothing waits on it for ever). Returns the handlers to put back. Main thread only."""
    if threading.current_thread() is not threading.main_thread():
        return {}
    return {s: signal.signal(s, _still_ignored) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}


def default_signals() -> None:
    """``preexec_fn``: the child's :data:`SIGNALS` at their defaults, no signal blocked."""
    for sig in SIGNALS:
        signal.signal(sig, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_SETMASK, ())


def end_group(proc: subprocess.Popen, grace_s: float = GRACE_S, group: bool = True) -> str | None:
    """End ``proc`` (its process group if ``group``): SIGHUP, SIGTERM after ``grace_s``, SIGKILL
    after another ``grace_s``; every wait bounded. Returns the signal that ended it (None: it had
    already ended; ``"SIGKILL (not reaped)"`` if even that did not within :data:`LAST_WAIT_S`)."""
    if proc.poll() is not None:
        return None
    for sig, wait_s in ((signal.SIGHUP, grace_s), (signal.SIGTERM, grace_s), (signal.SIGKILL, LAST_WAIT_S)):
        try:
            os.killpg(proc.pid, sig) if group else proc.send_signal(sig)
        except ProcessLookupError:
            pass
        except PermissionError:
            proc.send_signal(sig)
        try:
            proc.wait(timeout=wait_s)
            return sig.name
        except subprocess.TimeoutExpired:
            continue
    return "SIGKILL (not reaped)"


def bound_node_stops(net, grace_s: float = GRACE_S) -> None:
    """Every node of the Mininet ``net``: its shell ended by :func:`end_group` before Mininet's
    ``terminate`` (which sends SIGHUP and then waits without a timeout) runs."""
    for node in (*getattr(net, "hosts", ()), *getattr(net, "switches", ()), *getattr(net, "controllers", ())):
        if getattr(node, "_bounded_stop", False):
            continue
        original = node.terminate

        def terminate(node=node, original=original):
            shell = getattr(node, "shell", None)
            if shell is not None:
                if hasattr(node, "unmountPrivateDirs"):
                    node.unmountPrivateDirs()  # (through the shell: while it lives)
                    node.privateDirs = []
                end_group(shell, grace_s)
            original()

        node.terminate = terminate
        node._bounded_stop = True
