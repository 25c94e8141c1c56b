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

from report.registry import LOCK_WAIT_KEY, RERUN_KEY, Context, NotRun
from scenarios.calibrate import CANDIDATES

ROOT = Path(__file__).resolve().parents[1]
PAPER_SCENARIOS = ROOT / "scenarios" / "paper"
NETWORK_LOCK = "/tmp/sdvisc-net.lock"  # every run that builds a Mininet network holds it
RUN_TIMEOUT_S = 1800
LOCK_HELD_ENV = "SDVISC_NETWORK_LOCK_HELD"  # "1": the caller holds the lock for us (e.g. a test run under flock)


def scenario_path(name: str) -> Path:
    return PAPER_SCENARIOS / f"{name}.yaml"


SWITCH_PORTS: str | None = None
"""``--switch-ports`` for every run (``python -m report --switch-ports afxdp``); None: each scenario's own."""


def command(name: str) -> str:
    ports = f" --switch-ports {SWITCH_PORTS}" if SWITCH_PORTS else ""
    return f"./testbed run scenarios/paper/{name}.yaml{ports}"


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


LARGEST_CANDIDATE = max(CANDIDATES)  # the calibration's largest k (--calibrate-from takes no other)
_chosen_k: dict[str, float] = {}  # shape -> the k its last run's calibration chose (this report process)
_chosen_k_near: dict[str, float] = {}  # the same for the coarser key of :func:`neighbourhood_of`


def neighbourhood_of(data: dict) -> str:
    """Topology and sampling period only: runs that share them but not their ViSC turbines, SDCs or
    plant still cost about the same per sample (the same switches and hop counts, the same period)."""
    return json.dumps([data.get("topology"), data.get("step_s")], sort_keys=True)


def calibration_start(data: dict) -> float | None:
    """Where the calibration of an auto run starts its search (``--calibrate-from``): the k the last
    run of its shape chose, else the k the last run of its neighbourhood chose (same topology and
    period), else None (from k = 1). The search goes down from there while a k holds, else up, so the
    answer is the same smallest k; the start only saves the trials below it (≈ 2 s each)."""
    if data.get("time_scale") != "auto":
        return None  # a fixed time scale is not calibrated
    return _chosen_k.get(shape_of(data), _chosen_k_near.get(neighbourhood_of(data)))


def remember_calibration(data: dict, k: float) -> None:
    _chosen_k[shape_of(data)] = k
    _chosen_k_near[neighbourhood_of(data)] = k


def shape_of(data: dict) -> str:
    """What a calibration depends on in a scenario: topology, sampling period, plant model, SDCs and
    the ViSC turbines (their paths); runs of the same shape start their search at the k the last
    one chose (``--calibrate-from``: the same smallest k, found in two or three trials)."""
    visc = sorted({e["wt"] for e in data.get("timeline", []) if e.get("do") == "visc_on"})
    return json.dumps([data.get("topology"), data.get("step_s"), (data.get("plant") or {}).get("model"),
                       data.get("sdc"), visc], sort_keys=True)


def _run_file(ctx: Context, path: Path, name: str) -> tuple[dict, dict[str, np.ndarray]]:
    """Run ``path`` into <out>/runs/<name>. A calibrated run whose own measurement says it did not hold
    (:func:`did_not_hold`: over 1 % of the plant's steps or of a turbine's answers a sample late, or a
    converter trip beside a late answer) is run once more at twice its time scale; the first attempt stays beside it, its directory named
    ``<name>-k<k>-did-not-hold``, and the page's notes say so."""
    if os.geteuid() != 0:
        raise NotRun("cyber-in-the-loop runs need root (Mininet and Open vSwitch)")
    if shutil.which("ovs-vsctl") is None:
        raise NotRun("cyber-in-the-loop runs need Open vSwitch (./testbed sets it up)")
    out = ctx.out_dir / "runs" / name
    data = yaml.safe_load(path.read_text())
    start = calibration_start(data)
    extra = [] if start is None else ["--calibrate-from", f"{start:g}"]
    summary = _attempt(ctx, path, name, out, extra)
    k = summary.get("time", {}).get("time_scale")
    if did_not_hold(summary):
        held_not = out.with_name(f"{name}-k{k:g}-did-not-hold")
        shutil.rmtree(held_not, ignore_errors=True)
        out.rename(held_not)
        why = did_not_hold(summary)
        ctx.numbers.setdefault(RERUN_KEY, {})[name] = {"time_scale": k, "advice": why, "first_attempt": str(held_not)}
        ctx.notes.append(f"{name}: at the calibrated time scale {k:g} the run did not hold ({why}); "
                         f"run again at {2 * k:g}; the first attempt is in {held_not}")
        summary = _attempt(ctx, path, name, out, ["--time-scale", f"{2 * k:g}"])
        k = summary.get("time", {}).get("time_scale")
        if k <= LARGEST_CANDIDATE:  # the next run of this shape starts its search where this one held
            remember_calibration(data, k)
    elif summary.get("time", {}).get("calibration"):
        remember_calibration(data, k)
    ctx.numbers.setdefault("time_scale", {})[name] = k
    ctx.numbers.setdefault("switch_ports", {})[name] = (summary.get("switch_ports") or {}).get("used", "system")
    ctx.notes.append(f"{name}: time scale {k}, wall {summary.get('time', {}).get('wall_duration_s')} s, "
                     f"{summary.get('late_steps')} of {summary.get('steps')} steps late; output {out}")
    return summary, read_timeseries(out / "timeseries.csv")


def did_not_hold(summary: dict) -> str | None:
    """Why a run at the time scale its calibration chose did not hold (its own measurement), or None:
    the runner's ``advice``; or a converter that tripped while some of its answers came a sample late
    or more — at a fault's onset one late answer is enough (seen: F1net at k = 2, every turbine 99.3–99.5 %
    within one sample, all four tripped), and a trip that a late answer may have caused says nothing
    of the law. A trip with every answer in time is the physics' and stands. A run at a fixed time
    scale is what was asked for (B1net's added delay makes its answers late on purpose): never run again."""
    if not summary.get("time", {}).get("calibration"):
        return None
    if summary.get("advice"):
        return summary["advice"]
    turbines = summary.get("turbines", {})
    within = {wt: (t.get("round_trip_samples") or {}).get("within_one") for wt, t in turbines.items()}
    late = {wt: n for wt, n in (summary.get("converter_trips") or {}).items()
            if n and within.get(wt) is not None and within[wt] < 1.0}
    if late:
        return (f"converter trips {late} with answers a sample late or more: a late answer may have tripped them; "
                f"run again at --time-scale {2 * summary['time']['time_scale']:g}")
    return None


def _attempt(ctx: Context, path: Path, name: str, out: Path, extra: list[str]) -> dict:
    """One ``sdvisc run`` of ``path`` into ``out`` under the network lock; its summary."""
    out.mkdir(parents=True, exist_ok=True)
    cmd = [sys.executable, "-m", "scenarios.cli", "run", str(path), "--out", str(out), "--quiet", *extra]
    if SWITCH_PORTS:
        cmd += ["--switch-ports", SWITCH_PORTS]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p))
    with open(NETWORK_LOCK, "a") as lock:  # the same lock as flock(1) takes (flock(2) on the file)
        waited = time.perf_counter()
        if os.environ.get(LOCK_HELD_ENV) != "1":
            fcntl.flock(lock, fcntl.LOCK_EX)
        waited = time.perf_counter() - waited
        # the run inherits the locked file: if this process dies, the run still holds the lock until it ends
        proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=RUN_TIMEOUT_S,
                              pass_fds=(lock.fileno(),))
    waits = ctx.numbers.setdefault(LOCK_WAIT_KEY, {})  # other work's network runs, not ours
    waits[name] = round(waits.get(name, 0.0) + waited, 1)
    (out / "report_run.log").write_text(proc.stdout + proc.stderr)
    summary_path = out / "summary.json"
    if proc.returncode != 0 or not summary_path.exists():
        tail = " | ".join((proc.stderr or proc.stdout).strip().splitlines()[-3:])
        raise RuntimeError(f"{name}: the run ended with status {proc.returncode}: {tail}")
    return json.loads(summary_path.read_text())


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
