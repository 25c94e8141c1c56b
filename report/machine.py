"""The machine a report ran on (the page says what it was measured on)."""

from __future__ import annotations

import os
import platform
import time


def describe() -> dict:
    load1, load5, load15 = os.getloadavg()
    return {"cpu_count": os.cpu_count(), "load_average": [round(load1, 2), round(load5, 2), round(load15, 2)],
            "kernel": platform.release(), "platform": platform.platform(), "python": platform.python_version(),
            "written": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
