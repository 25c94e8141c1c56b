"""The calibration cache: ``time_scale: auto`` measures once per machine, code version and network
shape, and every later run of that shape starts at once with the k it found.

A calibration (:mod:`scenarios.calibrate`) costs seconds before t = 0 (2 s per candidate tried; 10–35 s
from k = 1). What it measures depends on three things only, which together are the cache's key:

* **the machine**: host name, CPU model, the CPUs this process may use, kernel release, the Open
  vSwitch datapath type;
* **the code**: a hash of every Python file of the packages that run in the loop (plant, SDC unit,
  SDN app, ground floor, topologies, scenarios) and of ``pyproject.toml`` — any change measures again;
* **the network shape**: the scenario's topology, sampling period, plant model and options, SDC and SDN
  sections, switch ports and links, CPU split, impaired links, and its ViSC turbines (their paths) —
  not its name, duration, description or the rest of its timeline.

Each run checks itself afterwards (its summary's ``advice``: over 1 % of the plant's steps or of a
turbine's answers a sample late). A run that did not hold writes twice its k into the cache (so the
next run of that shape holds without a warning) and says so; one that held confirms the entry. An
entry is measured again after :data:`MAX_AGE_S` (the machine's load and software drift) or on
``sdvisc run --recalibrate``. The file is JSON (``$SDVISC_CALIBRATION_CACHE``, else
``$XDG_CACHE_HOME/sdvisc/calibration.json``, else ``~/.cache/sdvisc/calibration.json``), written
atomically; an unreadable file is treated as empty and replaced. ``SDVISC_CALIBRATION_CACHE=none``
turns the cache off (every auto run measures; the tests' default, so each test measures its own).
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import socket
import time
from pathlib import Path

from scenarios.calibrate import CANDIDATES, Calibration
from scenarios.calibration_report import candidates_line
from sdvisc.jsonlines import write_json_atomic

CACHE_ENV = "SDVISC_CALIBRATION_CACHE"
CACHE_OFF = "none"
MAX_AGE_S = 14 * 24 * 3600.0
"""An entry older than this is measured again: a cached k is only as good as the machine it was
measured on, and a machine's background load and packages change over weeks."""
LOOP_PACKAGES = ("plant", "sdc_unit", "sdn_app", "sdvisc", "topologies", "scenarios", "host_tools")
"""The code a calibration depends on (host_tools: the CPU split sets the switch's CPU and scheduling)."""
ROOT = Path(__file__).resolve().parent.parent
LARGEST_K = float(max(CANDIDATES))


def default_path() -> Path | None:
    """The cache file, or None when ``$SDVISC_CALIBRATION_CACHE`` is ``none``."""
    if os.environ.get(CACHE_ENV) == CACHE_OFF:
        return None
    if os.environ.get(CACHE_ENV):
        return Path(os.environ[CACHE_ENV])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "sdvisc" / "calibration.json"


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def machine_key(datapath: str) -> dict:
    """What the measurement depends on in the machine."""
    return {"host": socket.gethostname(), "cpu": _cpu_model(), "cpus": len(os.sched_getaffinity(0)),
            "kernel": platform.release(), "datapath": datapath}


def code_version(root: Path = ROOT, packages: tuple[str, ...] = LOOP_PACKAGES) -> str:
    """A hash of the code that runs in the loop (16 hex digits): every ``*.py`` of ``packages`` under
    ``root`` and ``pyproject.toml``, by path and content."""
    digest = hashlib.sha256()
    files = sorted(p for pkg in packages for p in (root / pkg).rglob("*.py") if "__pycache__" not in p.parts)
    for path in [*files, root / "pyproject.toml"]:
        if path.is_file():
            digest.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()[:16]


def shape_of(scenario) -> dict:
    """What the measurement depends on in a scenario (a :class:`scenarios.schema.Scenario`)."""
    visc = sorted({e.wt for e in scenario.timeline if e.do == "visc_on"})
    dump = scenario.model_dump(mode="json")
    return {"topology": dump["topology"], "step_s": dump["step_s"], "plant": dump["plant"], "sdc": dump["sdc"],
            "sdn": dump["sdn"], "switch_ports": dump["switch_ports"], "switch_links": dump["switch_links"],
            "cpu_split": dump["cpu_split"], "switch_revalidation_ms": dump["switch_revalidation_ms"],
            "links": dump["links"], "impairable": dump["impairable"], "visc": visc}


def cache_key(machine: dict, code: str, shape: dict) -> str:
    text = json.dumps({"machine": machine, "code": code, "shape": shape}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:24]


class CalibrationCache:
    """The cache file (``path``; default :func:`default_path`; ``off``: no file, nothing kept);
    ``now`` is injected (seconds since the epoch) for tests."""

    def __init__(self, path: Path | None = None, now=time.time, off: bool = False) -> None:
        self.path = None if off else Path(path) if path is not None else default_path()
        self.now = now

    def _entries(self) -> dict:
        if self.path is None:
            return {}
        try:
            data = json.loads(self.path.read_text())
        except (OSError, ValueError):
            return {}
        return data if isinstance(data, dict) else {}

    def lookup(self, key: str) -> dict | None:
        """The entry for ``key`` if there is one younger than :data:`MAX_AGE_S`."""
        entry = self._entries().get(key)
        if not isinstance(entry, dict) or not isinstance(entry.get("time_scale"), (int, float)):
            return None
        if self.now() - float(entry.get("measured_at", 0)) > MAX_AGE_S:
            return None
        return entry

    def store(self, key: str, entry: dict) -> None:
        if self.path is None:
            return
        entries = self._entries()
        entries[key] = entry
        self.path.parent.mkdir(parents=True, exist_ok=True)
        write_json_atomic(self.path, entries)

    def remember_measured(self, key: str, calibration: dict, described: dict) -> dict:
        """Store what a calibration measured (its k and why); returns the entry."""
        entry = {"time_scale": calibration["time_scale"], "met": calibration["met"], "measured_at": self.now(),
                 "calibration_wall_s": calibration.get("wall_s"), "why": calibration_reason(calibration),
                 "runs_held": 0, "raised_from": None, **described}
        self.store(key, entry)
        return entry

    def record_outcome(self, key: str, k: float, advice: str | None) -> float | None:
        """After a run at the cached or measured ``k``: the k the next run of this shape starts with
        when this one did not hold (``advice``: its summary's), else None (the entry is confirmed)."""
        entry = self._entries().get(key)
        if not isinstance(entry, dict):
            return None
        if advice:
            entry.update(time_scale=min(2 * k, LARGEST_K), raised_from=k, why=f"a run at k = {k:g} did not hold "
                         f"({advice.split(':')[0]})", runs_held=0)
            self.store(key, entry)
            return entry["time_scale"]
        entry["runs_held"] = int(entry.get("runs_held", 0)) + 1
        self.store(key, entry)
        return None


def calibration_reason(calibration: dict) -> str:
    """Why the calibration chose its k, in a few words: the largest k that failed and what failed
    there, and what the chosen k measured."""
    trials = calibration.get("trials") or []
    chosen = next((t for t in trials if t["k"] == calibration["time_scale"]), None)
    failed = [t for t in trials if not t["ok"] and t["k"] < calibration["time_scale"]]
    parts = []
    if failed:
        worst = max(failed, key=lambda t: t["k"])
        parts.append(f"k = {worst['k']:g} fell short ({'; '.join(worst['why_not']) or 'no answer'})")
    if chosen is not None:
        p99 = chosen.get("answer_p99_sim_ms")
        held = "held" if chosen["ok"] else "fell short too (the largest tried)"
        parts.append(f"k = {chosen['k']:g} {held}: plant {chosen['plant_busy']:.0%} busy, SDC {chosen['sdc_busy']:.0%}, "
                     + (f"step start -> CTRL p99 {p99:.3f} ms simulated" if p99 is not None else "no ViSC turbine"))
    if not trials:
        parts.append("no candidate tried")
    return "; ".join(parts)


def _stamp(seconds: float) -> str:
    return time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime(seconds))


def choose_time_scale(run, cache: CalibrationCache | None = None, measure=None) -> dict:
    """The calibration of ``run`` (a :class:`scenarios.runner.Run` with its network built): the cache's
    entry for its key unless ``run.recalibrate``, else measured (``measure()``, default
    :meth:`scenarios.calibrate.Calibration.measure`) and stored. The result is what summary.json's
    ``time.calibration`` holds, with ``source`` (``cache``/``measured``), ``cache_key`` and ``line``
    (the one line the terminal shows: the k and why)."""
    cache = cache or CalibrationCache()
    key = cache_key(machine_key(run.datapath), code_version(), shape_of(run.scenario))
    entry = None if getattr(run, "recalibrate", False) else cache.lookup(key)
    if entry is not None:
        k = float(entry["time_scale"])
        return {"time_scale": k, "met": bool(entry.get("met", True)), "source": "cache", "cache_key": key,
                "cache_file": str(cache.path), "cached": entry, "trials": [], "wall_s": 0.0,
                "line": (f"sdvisc: time scale {k:g} from the calibration cache (measured {_stamp(entry['measured_at'])} "
                         f"on this machine, code and network shape: {entry['why']}; --recalibrate measures again)")}
    calibration = (measure or Calibration(run).measure)()
    entry = cache.remember_measured(key, calibration, {"scenario": run.scenario.name})
    verdict = "" if calibration["met"] else " (limits NOT met at the largest k tried)"
    kept = "cached for the next run of this shape" if cache.path else "calibration cache off"
    return {**calibration, "source": "measured", "cache_key": key, "cache_file": cache.path and str(cache.path),
            "line": (f"sdvisc: time scale {calibration['time_scale']:g}{verdict}, calibrated in "
                     f"{calibration['wall_s']:.1f} s: {entry['why']}; {kept}"
                     + (f"; candidates: {candidates_line(trials)}" if (trials := calibration.get("trials")) else ""))}


def after_run(calibration: dict, advice: str | None, cache: CalibrationCache | None = None) -> dict:
    """Check the chosen k against the run's own measurement (``advice``) and update the cache; returns
    ``{"held": bool, "next_run_k": k or None}`` for summary.json's ``time.calibration``."""
    if cache is None:
        path = calibration.get("cache_file")
        cache = CalibrationCache(Path(path)) if path else CalibrationCache(off=True)
    raised = cache.record_outcome(calibration["cache_key"], float(calibration["time_scale"]), advice)
    return {"held": advice is None, "next_run_k": raised}
