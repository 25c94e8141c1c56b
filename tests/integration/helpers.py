"""Running the real testbed from tests: subprocess wrappers and leftover checks."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
TEST_TIME_SCALE = os.environ.get("SDVISC_TEST_TIME_SCALE", "2")
"""Network tests run in virtual time with this headroom (k wall seconds per simulated second), so
their assertions hold on a busy machine; they assert simulated-time behaviour, never this
machine's real-time speed (that is measured in benchmarks/). A test's own --time-scale wins."""


def time_scale_args() -> list[str]:
    return ["--time-scale", TEST_TIME_SCALE]


def sdvisc(*args: str, timeout: float = 300, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "scenarios.cli", *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=timeout, env=dict(os.environ, PYTHONUNBUFFERED="1"), **kw)


def run_scenario(path: str | Path, out: Path, *extra: str, timeout: float = 300) -> dict:
    res = sdvisc("run", str(path), "--out", str(out), "--quiet", *time_scale_args(), *extra,
                 timeout=timeout * float(TEST_TIME_SCALE))
    assert res.returncode == 0, f"sdvisc run failed ({res.returncode}):\n{res.stdout}\n{res.stderr}"
    return json.loads((out / "summary.json").read_text())


def assert_no_leftovers() -> None:
    from sdvisc.cleanup import leftovers

    left = leftovers()
    assert left == {"processes": [], "bridges": [], "links": []}, f"a run left things behind: {left}"
    # Mininet host shells are gone too (their network namespaces die with them)
    shells = subprocess.run(["pgrep", "-f", "mininet:"], capture_output=True, text=True).stdout.split()
    assert not shells, f"Mininet host shells left: {shells}"
