"""Commands as JSON lines on a non-blocking file descriptor (the runner → plant / OWFCC channel)."""

from __future__ import annotations

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
