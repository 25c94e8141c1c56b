"""A file that always holds the newest of a series of snapshots, written off the caller's thread.

A paced loop (the plant's steps) or an event loop must not wait for the disk: replacing a file on
ext4 can take milliseconds when the file system is busy (a rename over an existing file makes
ext4 flush the new file's data, ``auto_da_alloc``), which is several plant steps. :class:`LatestWriter`
takes the snapshot's bytes and returns at once; a daemon thread writes the newest one it has
(older ones not yet written are skipped: a reader only ever wants the newest) with one write to
a temporary file and a rename, so a reader never sees half a file. :meth:`close` writes the last
snapshot before it returns.

Dependencies: the standard library only (``threading``; under eventlet's monkey patching use the
original ``threading``, which :func:`_threading` does).
"""

from __future__ import annotations

import os
import sys


def _threading():
    """The real ``threading`` module, also where eventlet has patched it to green threads."""
    if "eventlet" in sys.modules:
        from eventlet import patcher  # noqa: PLC0415 - only where eventlet is already in use

        return patcher.original("threading")
    import threading  # noqa: PLC0415

    return threading


class LatestWriter:
    """Write the newest snapshot to ``path`` in a background thread (see the module docstring)."""

    def __init__(self, path: str | os.PathLike) -> None:
        threading = _threading()
        self.path = os.fspath(path)
        self._tmp = f"{self.path}.{os.getpid()}.latest.tmp"  # only the writer thread uses it
        self._pending: bytes | None = None
        self._cond = threading.Condition()
        self._closed = False
        self.written = 0  # snapshots written
        self.skipped = 0  # snapshots replaced by a newer one before they were written
        self.errors = 0  # writes that failed (the next snapshot tries again)
        self._thread = threading.Thread(target=self._run, name=f"latest-writer:{os.path.basename(self.path)}",
                                        daemon=True)
        self._thread.start()

    def put(self, data: bytes) -> None:
        """Hand over a snapshot; returns at once."""
        with self._cond:
            if self._closed:
                raise ValueError("LatestWriter is closed")
            if self._pending is not None:
                self.skipped += 1
            self._pending = data
            self._cond.notify()

    def close(self) -> None:
        """Write the last snapshot handed over (if any) and stop the thread."""
        with self._cond:
            self._closed = True
            self._cond.notify()
        self._thread.join()

    def _run(self) -> None:
        while True:
            with self._cond:
                while self._pending is None and not self._closed:
                    self._cond.wait()
                data, self._pending = self._pending, None
                closed = self._closed
            if data is not None:
                self._write(data)
            if closed:  # (put() refuses snapshots once closed: nothing can be left behind)
                return

    def _write(self, data: bytes) -> None:
        try:
            fd = os.open(self._tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
            try:
                os.write(fd, data)
            finally:
                os.close(fd)
            os.replace(self._tmp, self.path)
            self.written += 1
        except OSError:
            self.errors += 1
