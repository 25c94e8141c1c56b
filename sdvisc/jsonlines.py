"""Commands as JSON lines on a non-blocking file descriptor (the runner → plant / OWFCC channel)."""

from __future__ import annotations

import itertools
import json
import os


class JsonLineReader:
    """Reads what is available on ``fd`` without blocking and returns the complete JSON lines."""

    def __init__(self, fd: int) -> None:
        self.fd = fd
        self.open = True
        self._buf = b""
        os.set_blocking(fd, False)

    def read(self) -> list[dict]:
        """The complete lines received so far, parsed; sets ``open`` False at end of file."""
        try:
            chunk = os.read(self.fd, 65536)
        except BlockingIOError:
            return []
        if not chunk:
            self.open = False
            return []
        self._buf += chunk
        *lines, self._buf = self._buf.split(b"\n")
        return [json.loads(line) for line in lines if line.strip()]


_write_count = itertools.count(1)  # next() is atomic: threads never share a temporary name


def write_json_atomic(path, obj) -> None:
    """Replace ``path`` with ``obj`` as JSON so that a reader never sees a partial file.

    The text goes to a temporary file of its own (process id and a counter in the name) in one
    ``os.write``, then ``os.replace`` moves it into place. A writer interrupted at any point (e.g. by
    the SIGTERM that stops a run) cannot leave bytes in a file another write has since renamed:
    a shared temporary name and a buffered file object could (that gave an ``sdn_state.json`` with
    trailing garbage)."""
    path = os.fspath(path)
    tmp = f"{path}.{os.getpid()}.{next(_write_count)}.tmp"
    data = json.dumps(obj, indent=1, sort_keys=True).encode()
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
    try:
        os.write(fd, data)
    finally:
        os.close(fd)
    os.replace(tmp, path)
