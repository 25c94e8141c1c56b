"""Shared machinery of the claim sensitivity study: a parameter (or open choice) and the values it is
tried at, how a change is applied to the offline farm's cases, JSON and commit helpers."""

from __future__ import annotations

import contextlib
import subprocess
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

import plant.cases as cases
from plant.params import PlantParams
from plant.wpp import legacy_params

RANGE = "range"  # a parameter with a source and a range: its ends may go into the "best corner"
OPEN = "open choice"  # an alternative the paper leaves open (structure, bus, reading): never in the corner
AMBIGUITY = OPEN  # the name the study used before (issue 28)


@dataclass(frozen=True)
class Param:
    """One parameter (or one open choice of the paper's) and the values it is tried at."""

    name: str
    changes: dict  # value label -> {"part.field": value}; the first entry is the low end, the last the high end
    default: str  # what the default is, in words
    source: str  # where the range / the alternative comes from, and why these values
    kind: str = RANGE


# Special keys (not fields of a parameter set):
#   "wpp.legacy": True      the plant controller as before issue 39 (plant.wpp.legacy_params), applied first
#   "case.<option>"         options of the evaluation itself (z_f, ramp, ki_per_scr, ...), see the eval_* functions
def split(changes: dict) -> tuple[dict, dict, dict]:
    """(plant-parameter changes, ViscParams changes, case options)."""
    plant_ch, visc, case = {}, {}, {}
    for key, value in changes.items():
        part, field = key.split(".", 1)
        if part == "visc":
            visc[field] = value
        elif part == "case":
            case[field] = value
        else:
            plant_ch[key] = value
    return plant_ch, visc, case


def apply(pp: PlantParams, plant_ch: dict) -> PlantParams:
    if plant_ch.get("wpp.legacy"):
        pp.wpp = legacy_params(pp.wpp)
    for key, value in plant_ch.items():
        if key == "wpp.legacy":
            continue
        part, field = key.split(".", 1)
        obj = pp if part == "plant" else getattr(pp, part)
        if not hasattr(obj, field):
            raise TypeError(f"unknown parameter {key!r}")
        if part == "wpp":  # WppParams may be frozen or shared: replace it
            pp.wpp = replace(pp.wpp, **{field: value})
        else:
            setattr(obj, field, value)
    return pp


@contextlib.contextmanager
def patched(plant_ch: dict):
    """plant.cases builds its PlantParams with ``plant_ch`` applied (the cases' own set-up otherwise);
    the report's cases (report/plantcases.py) are plant.cases' functions, so they are patched too."""
    original = cases._params

    def params(sc_connected, grid):
        pp = original(sc_connected, grid)
        enabled = pp.wpp.enabled  # a case's wpp_enabled=False (F8) stays unless the change sets it
        pp = apply(pp, plant_ch)
        if "wpp.enabled" not in plant_ch:
            pp.wpp = replace(pp.wpp, enabled=enabled)
        return pp

    cases._params = params
    try:
        yield
    finally:
        cases._params = original


def rel(x, paper) -> float:
    return abs(x - paper) if x is not None else float("inf")


def fmt(x) -> str:
    return "—" if x is None else f"{x:.3f}" if isinstance(x, float) else str(x)


def jsonable(x):
    if isinstance(x, dict):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    if isinstance(x, np.bool_):
        return bool(x)
    if isinstance(x, np.ndarray):
        return jsonable(x.tolist())
    if isinstance(x, float) and not np.isfinite(x):
        return None if np.isnan(x) else ("inf" if x > 0 else "-inf")
    return x


def commit() -> str:
    def git(*a: str) -> str:
        return subprocess.run(["git", *a], capture_output=True, text=True, cwd=Path(__file__).parent).stdout.strip()
    head = git("rev-parse", "HEAD") or "unknown"
    return head + (" + uncommitted changes" if git("status", "--porcelain", "--", "plant", "report", "sdc_unit")
                   else "")
