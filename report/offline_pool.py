"""The offline experiments on two cores: this process and one worker forked before anything runs.

The offline experiments are plain CPU work in one process each (no network, no clock), and the
network experiments after them need a quiet machine (their time scale is calibrated on it), so
the report runs the offline part on both cores first and only then the network part.

An experiment with ``keeps_for`` (F7's boundary search, F9's runs: kept in this process for F7net
and F9net) runs here; the others are shared: this process and the worker each take the next one
when free (the shared ones from the registry's last, the long sweeps beyond the paper, to its first). The worker is forked once, before any experiment or
thread exists, and gets experiment *indices* (it has the same list), so nothing but the results
crosses the pipe: an experiment's function need not be picklable. What the worker returns is the
outcome without its experiment; a worker that dies is reported as a failure of the experiment it
had, and the others then run here.
"""

from __future__ import annotations

import multiprocessing
import os
import queue
import threading
from collections import deque
from collections.abc import Callable

from report.registry import Experiment

_STOP = -1


def worth_it(experiments: list[Experiment], indices: list[int]) -> bool:
    """Two cores and at least one shared offline experiment besides another one to run here."""
    shared = [i for i in indices if not experiments[i].keeps_for]
    return (os.cpu_count() or 1) >= 2 and len(indices) >= 2 and len(shared) >= 1


def run_offline(experiments: list[Experiment], indices: list[int], run_one: Callable[[Experiment], object],
                done: Callable[[int, object], None], failed: Callable[[Experiment, str], object]) -> None:
    """Run ``experiments[i]`` for ``i`` in ``indices`` on two cores; ``done(i, outcome)`` is called in
    this thread for each, as they finish (``run_one(exp)`` makes an outcome; ``failed(exp, error)``
    the outcome of an experiment whose worker died)."""
    here = deque(i for i in indices if experiments[i].keeps_for)
    # the registry's last first: the sweeps beyond the paper (B2, B1) are the longest, and a long one
    # started last would leave the other core idle at the end
    shared = deque(reversed([i for i in indices if not experiments[i].keeps_for]))
    lock = threading.Lock()
    results: queue.Queue = queue.Queue()
    ctx = multiprocessing.get_context("fork")
    to_worker, from_parent = ctx.Pipe()
    to_parent, from_worker = ctx.Pipe()
    worker = ctx.Process(target=_serve, args=(experiments, run_one, from_parent, to_parent), daemon=True,
                         name="report-offline-worker")
    worker.start()  # forked now: no experiment has run, no thread of ours exists
    from_parent.close()
    to_parent.close()

    def take() -> int | None:
        with lock:
            return shared.popleft() if shared else None

    def feed() -> None:
        while (i := take()) is not None:
            try:
                to_worker.send(i)
                results.put((i, from_worker.recv()))
            except (EOFError, OSError):
                worker.join(timeout=5)  # reaped, so that its exit code is known
                code = worker.exitcode if worker.exitcode is not None else "unknown"
                results.put((i, failed(experiments[i], f"the offline worker process died (exit code {code})")))
                return  # the rest runs here
        try:
            to_worker.send(_STOP)
        except OSError:
            pass

    feeder = threading.Thread(target=feed, name="report-offline-feeder", daemon=True)
    feeder.start()
    remaining = len(indices)
    try:
        while remaining:
            i = here.popleft() if here else take()
            if i is not None:
                results.put((i, run_one(experiments[i])))
            # the finished ones, each once; when nothing is left to take, wait for the worker's (if it
            # died, take() hands what it left back to this loop)
            block = i is None
            while remaining:
                try:
                    j, outcome = results.get(block=block, timeout=0.5 if block else None)
                except queue.Empty:
                    break
                remaining -= 1
                done(j, outcome)
                block = False
    finally:
        feeder.join(timeout=5)
        worker.join(timeout=5)
        if worker.is_alive():
            worker.kill()
            worker.join()
        to_worker.close()
        from_worker.close()


def _serve(experiments: list[Experiment], run_one, conn_in, conn_out) -> None:
    """The worker: run the experiment of each index received, send back its outcome (without the
    experiment itself, which may hold a function pickle cannot carry)."""
    while True:
        try:
            i = conn_in.recv()
        except EOFError:
            return
        if i == _STOP:
            return
        conn_out.send(run_one(experiments[i]))
