"""Import ``dpsimpy`` without writing into ``$HOME`` or the working directory.

Importing DPsim 1.4.0 creates ``$HOME/OpenDSS`` (its bundled OpenDSS-C) and a simulation writes
``./logs`` unless ``Logger.set_log_dir`` points elsewhere (docs/plant.md, "EMT backend"). Here HOME is a
temporary directory during the import and the log directory another one; both are removed at exit.
"""

from __future__ import annotations

import atexit
import os
import shutil
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
