"""Running scenarios from a benchmark: one ``sdvisc run`` per scenario in a subprocess (it needs
root), its summary.json read back; and the machine a figure was measured on."""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parent.parent


def run_file(path: Path, out: Path, *extra: str, timeout: float = 3600) -> dict:
    """Run the scenario file ``path`` into ``out`` (``extra``: more ``sdvisc run`` options)."""
    res = subprocess.run([sys.executable, "-m", "scenarios.cli", "run", str(path), "--out", str(out), "--quiet",
                          *extra], cwd=ROOT, capture_output=True, text=True, timeout=timeout)
    if res.returncode != 0:
        raise RuntimeError(f"{path.name} failed:\n{res.stdout}\n{res.stderr}")
    return json.loads((out / "summary.json").read_text())


def run_dict(scenario: dict, work: Path, *extra: str, timeout: float = 3600) -> dict:
    """Write ``scenario`` as ``work/<name>.yaml`` and run it into ``work/<name>``."""
    path = work / f"{scenario['name']}.yaml"
    path.write_text(yaml.safe_dump(scenario, sort_keys=False))
    return run_file(path, work / scenario["name"], *extra, timeout=timeout)


def machine() -> dict:
    return {"platform": platform.platform(), "cpus": os.cpu_count(), "python": platform.python_version(),
            "load": os.getloadavg()}


def work_dir(out: Path | None, prefix: str) -> Path:
    """The benchmark's working directory (``out``, else a new temporary one); root is required."""
    if os.geteuid() != 0:
        raise SystemExit("needs root")
    work = out or Path(tempfile.mkdtemp(prefix=prefix))
    work.mkdir(parents=True, exist_ok=True)
    return work


def finish(result: dict) -> int:
    """Stamp ``result`` with the load after and the machine, print it as JSON; the exit code."""
    result["load_after"] = os.getloadavg()
    result["machine"] = machine()
    print(json.dumps(result, indent=1))
    return 0
