"""Import ``dpsimpy`` without writing into ``$HOME`` or the working directory.

Importing DPsim 1.4.0 creates ``$HOME/OpenDSS`` (its bundled OpenDSS-C) and a simulation writes
``./logs`` unless ``Logger.set_log_dir`` points elsewhere (docs/plant.md, "EMT backend"). Here HOME is a
temporary directory during the import and the log directory another one; both are removed at exit.
"""

from __future__ import annotations

import atexit
import contextlib
import os
import shutil
import sys
import tempfile

_DPSIM = None
_TMP: str | None = None


def available() -> bool:
    """Whether the optional ``emt`` extra (PyPI ``dpsim``) is installed."""
    import importlib.util  # noqa: PLC0415

    return importlib.util.find_spec("dpsimpy") is not None


def scratch_dir() -> str:
    """The process's temporary directory for DPsim's files (created once, removed at exit)."""
    global _TMP
    if _TMP is None:
        _TMP = tempfile.mkdtemp(prefix="sdvisc-dpsim-")
        atexit.register(shutil.rmtree, _TMP, True)
    return _TMP


def dpsim():
    """The ``dpsimpy`` module, imported once with HOME and the log directory in :func:`scratch_dir`."""
    global _DPSIM
    if _DPSIM is None:
        home = os.environ.get("HOME")
        os.environ["HOME"] = scratch_dir()
        try:
            import dpsimpy  # noqa: PLC0415
        finally:
            if home is None:
                os.environ.pop("HOME", None)
            else:
                os.environ["HOME"] = home
        dpsimpy.Logger.set_log_dir(os.path.join(scratch_dir(), "logs"))
        _DPSIM = dpsimpy
    return _DPSIM


def emt_simulation(name: str, system, step_s: float, final_time_s: float):
    """A DPsim EMT simulation of ``system`` at ``step_s`` up to ``final_time_s``, initialised from the
    system's node voltages and terminals (no start-up transient), its logging off; not started."""
    d = dpsim()
    sim = d.Simulation(name, d.LogLevel.off)
    sim.set_system(system)
    sim.set_domain(d.Domain.EMT)
    sim.set_time_step(step_s)
    sim.set_final_time(final_time_s)
    sim.do_init_from_nodes_and_terminals(True)
    return sim


class OwnsSimulation:
    """A backend that steps a DPsim simulation it started (``self.sim``): :meth:`close` stops it, once."""

    def _started(self, sim) -> None:
        """``sim`` (:func:`emt_simulation`, its attribute handles fetched) started and now owned."""
        self.sim = sim
        sim.start()
        self._running = True

    def close(self) -> None:
        """Stop DPsim's simulation (idempotent)."""
        if getattr(self, "_running", False):
            self._running = False
            self.sim.stop()


@contextlib.contextmanager
def native_stdout_silenced():
    """File descriptors 1 and 2 sent to /dev/null for the block: DPsim's C++ prints "Handle event time ..."
    on every switch event straight to the process's stdout and "[... MnaSolverFactory info] creating
    KLUAdapter ..." to its stderr at every start (neither ``LogLevel.off`` nor the Python streams reach
    them), which would land in the report's output. Python's buffers are flushed before, so what it wrote
    earlier still appears; what anything writes to them inside the block is discarded (the run loops print
    nothing; an exception raised inside propagates and is printed after the block)."""
    for stream in (sys.stdout, sys.stderr):
        stream.flush()
    saved = [os.dup(1), os.dup(2)]
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
        yield
    finally:
        for stream in (sys.stdout, sys.stderr):
            stream.flush()
        for fd, copy in zip((1, 2), saved):
            os.dup2(copy, fd)
            os.close(copy)
        os.close(devnull)
