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


os.environ.setdefault("SDVISC_CALIBRATION_CACHE", "none")
"""Every ``time_scale: auto`` run a test starts measures its own calibration (the cache off,
scenarios/calibration_cache.py), so no test depends on what an earlier one left in a cache; a test of
the cache itself names its own file."""


def time_scale_args() -> list[str]:
    return ["--time-scale", TEST_TIME_SCALE]


def sdvisc(*args: str, timeout: float = 300, env: dict | None = None, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "scenarios.cli", *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=timeout, env=env or dict(os.environ, PYTHONUNBUFFERED="1"), **kw)


def run_scenario(path: str | Path, out: Path, *extra: str, timeout: float = 300) -> dict:
    res = sdvisc("run", str(path), "--out", str(out), "--quiet", *time_scale_args(), *extra,
                 timeout=timeout * float(TEST_TIME_SCALE))
    assert res.returncode == 0, f"sdvisc run failed ({res.returncode}):\n{res.stdout}\n{res.stderr}"
    for name in ("sdn_events.jsonl", "sdn2_events.jsonl"):
        assert_decisions_in_order(out / name)
    return json.loads((out / "summary.json").read_text())


def assert_decisions_in_order(events_file: Path) -> None:
    """The SDN app takes one decision at a time: its events are written in the order of their
    clock readings (two of its threads deciding at once wrote a later tick's DR between a link-up
    and the restoration it caused)."""
    if not events_file.exists():
        return
    stamps = [json.loads(line)["t_wall"] for line in events_file.read_text().splitlines() if line.strip()]
    behind = [(i, a, b) for i, (a, b) in enumerate(zip(stamps, stamps[1:])) if b < a]
    assert not behind, f"{events_file.name}: events written out of clock order (line, earlier, later): {behind[:5]}"


def assert_no_leftovers() -> None:
    from host_tools.cleanup import leftovers

    left = leftovers()
    assert left == {"processes": [], "bridges": [], "links": [], "netns": [], "cpu_split": [],
                    "switch_revalidation": [], "servers": []}, \
        f"a run left things behind: {left}"
    # Mininet host shells are gone too (their network namespaces die with them); a shell's command line
    # is Mininet's own (a user's process that merely names "mininet:x" is no shell: issue 42)
    shells = subprocess.run(["pgrep", "-f", "^bash --norc --noediting -is mininet:"], capture_output=True,
                            text=True).stdout.split()
    assert not shells, f"Mininet host shells left: {shells}"
