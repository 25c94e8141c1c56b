"""Cyber-in-the-loop runs for the report: a scenario of scenarios/paper/ through the normal runner,
as a subprocess (``python -m scenarios.cli run FILE --out DIR``) under the network lock, read back
from its summary.json and timeseries.csv. Never imports scenarios/ (floors)."""

from __future__ import annotations

import csv
import fcntl
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import yaml

from report.registry import LOCK_WAIT_KEY, Context, NotRun

ROOT = Path(__file__).resolve().parents[1]
PAPER_SCENARIOS = ROOT / "scenarios" / "paper"
NETWORK_LOCK = "/tmp/sdvisc-net.lock"  # every run that builds a Mininet network holds it
RUN_TIMEOUT_S = 1800
LOCK_HELD_ENV = "SDVISC_NETWORK_LOCK_HELD"  # "1": the caller holds the lock for us (e.g. a test run under flock)


def scenario_path(name: str) -> Path:
    return PAPER_SCENARIOS / f"{name}.yaml"


def command(name: str) -> str:
    return f"./testbed run scenarios/paper/{name}.yaml"


def run(ctx: Context, name: str) -> tuple[dict, dict[str, np.ndarray]]:
    """Run scenarios/paper/<name>.yaml into <out>/runs/<name>; (summary, timeseries columns)."""
    return _run_file(ctx, scenario_path(name), name)


def run_variant(ctx: Context, name: str, label: str, changes: dict) -> tuple[dict, dict[str, np.ndarray]]:
    """Run scenarios/paper/<name>.yaml with ``changes`` applied (``{"timeline": fn}`` maps the timeline
    list; other keys replace top-level keys), written to <out>/scenarios/<label>.yaml and run into
    <out>/runs/<label>: e.g. the F7 case at the SCR the offline search found."""
    return _run_file(ctx, write_variant(ctx.out_dir / "scenarios", name, label, changes), label)


def write_variant(directory: Path, name: str, label: str, changes: dict) -> Path:
    """scenarios/paper/<name>.yaml with ``changes`` applied (see :func:`run_variant`), named
    ``label``, written to <directory>/<label>.yaml."""
    data = apply_changes(load(name), changes)
    data["name"] = label
    path = directory / f"{label}.yaml"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f"# {name} with {', '.join(changes)} changed by the report\n" + yaml.safe_dump(data, sort_keys=False))
    return path


def apply_changes(data: dict, changes: dict) -> dict:
    """``data`` (a scenario as plain data) with ``changes``: a callable maps the key's value, anything
    else replaces it."""
    data = dict(data)
    for key, value in changes.items():
        data[key] = value(data[key]) if callable(value) else value
    return data


def known_time_scale(data: dict) -> float | None:
    """The k the calibration chose for a run of this scenario's shape earlier in this process."""
    return _chosen_k.get(shape_of(data))


_chosen_k: dict[str, float] = {}  # shape -> the k its last run's calibration chose (this report process)


def shape_of(data: dict) -> str:
    """What a calibration depends on in a scenario: topology, sampling period, plant model, SDCs and
    the ViSC turbines (their paths); runs of the same shape start their search at the k the last
    one chose (``--calibrate-from``: the same smallest k, found in two or three trials)."""
    visc = sorted({e["wt"] for e in data.get("timeline", []) if e.get("do") == "visc_on"})
    return json.dumps([data.get("topology"), data.get("step_s"), (data.get("plant") or {}).get("model"),
                       data.get("sdc"), visc], sort_keys=True)


def _run_file(ctx: Context, path: Path, name: str) -> tuple[dict, dict[str, np.ndarray]]:
    if os.geteuid() != 0:
        raise NotRun("cyber-in-the-loop runs need root (Mininet and Open vSwitch)")
    if shutil.which("ovs-vsctl") is None:
        raise NotRun("cyber-in-the-loop runs need Open vSwitch (./testbed sets it up)")
    out = ctx.out_dir / "runs" / name
    out.mkdir(parents=True, exist_ok=True)
    cmd = [sys.executable, "-m", "scenarios.cli", "run", str(path), "--out", str(out), "--quiet"]
    data = yaml.safe_load(path.read_text())
    shape = shape_of(data)
    if data.get("time_scale") == "auto" and shape in _chosen_k:  # a fixed time scale is not calibrated
        cmd += ["--calibrate-from", f"{_chosen_k[shape]:g}"]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p))
    with open(NETWORK_LOCK, "a") as lock:  # the same lock as flock(1) takes (flock(2) on the file)
        waited = time.perf_counter()
        if os.environ.get(LOCK_HELD_ENV) != "1":
            fcntl.flock(lock, fcntl.LOCK_EX)
        waited = time.perf_counter() - waited
        # the run inherits the locked file: if this process dies, the run still holds the lock until it ends
        proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=RUN_TIMEOUT_S,
                              pass_fds=(lock.fileno(),))
    ctx.numbers.setdefault(LOCK_WAIT_KEY, {})[name] = round(waited, 1)  # other work's network runs, not ours
    (out / "report_run.log").write_text(proc.stdout + proc.stderr)
    summary_path = out / "summary.json"
    if proc.returncode != 0 or not summary_path.exists():
        tail = " | ".join((proc.stderr or proc.stdout).strip().splitlines()[-3:])
        raise RuntimeError(f"{name}: the run ended with status {proc.returncode}: {tail}")
    summary = json.loads(summary_path.read_text())
    k = summary.get("time", {}).get("time_scale")
    if summary.get("time", {}).get("calibration"):
        _chosen_k[shape] = k
    ctx.numbers.setdefault("time_scale", {})[name] = k
    ctx.notes.append(f"{name}: time scale {k}, wall {summary.get('time', {}).get('wall_duration_s')} s, "
                     f"{summary.get('late_steps')} of {summary.get('steps')} steps late; waited {waited:.0f} s for the network "
                     f"lock; output {out}")
    return summary, read_timeseries(out / "timeseries.csv")


def read_timeseries(path: Path) -> dict[str, np.ndarray]:
    with open(path, newline="") as f:
        header = next(csv.reader(f))
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {name: data[:, j] for j, name in enumerate(header)}


def load(name: str) -> dict:
    """scenarios/paper/<name>.yaml as plain data (the report never imports scenarios/)."""
    return yaml.safe_load(scenario_path(name).read_text())


def timeline(name: str) -> list[dict]:
    return load(name)["timeline"]


def packet_rate(ts: dict[str, np.ndarray], wt: str) -> tuple[np.ndarray, np.ndarray]:
    """CTRL packets per simulated second received by ``wt`` (from the cumulative count)."""
    t, n = ts["t"], ts[f"{wt}.ctrl_rx"]
    return t[1:], np.diff(n) / np.diff(t)


def settle_time(t: np.ndarray, y: np.ndarray, t0: float, t1: float, band: float) -> float:
    """Time after t0 after which y stays within ``band`` of its mean over the last 0.3 s before t1."""
    final = float(np.mean(y[(t > t1 - 0.3) & (t <= t1)]))
    inside = (t > t0) & (t <= t1)
    outside = np.nonzero(inside & (np.abs(y - final) > band))[0]
    return float(t[outside[-1]] - t0) if len(outside) else 0.0
