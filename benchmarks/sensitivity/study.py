"""The tornado study: every variation of a group evaluated once, the best corner of the sourced
ranges, and per claim the rows with their values and verdicts. An open choice (an alternative the
paper leaves open: structure, bus, reading, fault type or resistance) that reaches the paper is
"consistent", never "yes"; it never goes into the corner."""

from __future__ import annotations

import time

from benchmarks.sensitivity.claims import GROUPS, Claim
from benchmarks.sensitivity.common import OPEN, RANGE, rel, split
from plant.params import PlantParams
from report.verdicts import CONSISTENT
from sdc_unit.params import ViscParams

CASE_DEFAULTS = {"z_f": 0.0, "p_before_zero": False}
RANGE_OPTIONS = {"F7": {"case.xtol": 0.05}}  # the range rows' F7 bisections to 0.05 (run time; the default,
# the structural rows and the corner to the report's 0.02)


def is_default(changes: dict) -> bool:
    """Whether ``changes`` sets every value to the default it already has (then the default run is reused)."""
    plant_ch, visc, case = split(changes)
    pp, vp = PlantParams(), ViscParams()
    if "wpp.legacy" in plant_ch:
        return False
    return (all(getattr(pp if k.split(".")[0] == "plant" else getattr(pp, k.split(".")[0]), k.split(".", 1)[1]) == v
                for k, v in plant_ch.items())
            and all(getattr(vp, k) == v for k, v in visc.items())
            and all(k in CASE_DEFAULTS and CASE_DEFAULTS[k] == v for k, v in case.items()))


def params_of(group: str) -> tuple:
    _, ranged, structural = GROUPS[group]
    return tuple(ranged) + tuple(structural)


def sweep_group(group: str, log) -> dict:
    """Every variation of the group's parameters, evaluated once each: {"default": r, param: {label: r}}."""
    evaluate = GROUPS[group][0]
    t0 = time.time()
    out = {"default": evaluate({})}
    log(f"{group}: default done ({time.time() - t0:.1f} s)")
    for prm in params_of(group):
        out[prm.name] = {}
        extra = RANGE_OPTIONS.get(group, {}) if prm.kind == RANGE else {}
        for label, ch in prm.changes.items():
            out[prm.name][label] = out["default"] if is_default(ch) else evaluate({**ch, **extra})
        log(f"{group}: {prm.name} done ({time.time() - t0:.1f} s)")
    return out


def corner(claim: Claim, group_runs: dict) -> tuple[dict, dict]:
    """Each range parameter at whichever end (or the default) brings the claim closest to the paper."""
    changes, chosen = {}, {}
    base = claim.towards(group_runs["default"])
    for prm in params_of(claim.group):
        if prm.kind != RANGE:
            continue
        best_label, best = None, base
        for label, r in group_runs[prm.name].items():
            d = claim.towards(r)
            if d < best:
                best_label, best = label, d
        if best_label is not None:
            chosen[prm.name] = best_label
            changes.update(prm.changes[best_label])
    return changes, chosen


def verdict(claim: Claim, x, r: dict, kind: str) -> str:
    v = claim.judge(x, r)
    return CONSISTENT if kind == OPEN and v == "yes" else v


def _row(claim: Claim, name: str, kind: str, default: str, source: str, changes: dict, runs: dict) -> dict:
    values = {label: claim.value(r) for label, r in runs.items()}
    verdicts = {k: verdict(claim, values[k], r, kind) for k, r in runs.items()}
    row = {"parameter": name, "kind": kind, "default": default, "source": source, "changes": changes,
           "values": values, "verdicts": verdicts,
           "reaches": [k for k, v in verdicts.items() if v in ("yes", CONSISTENT)]}
    if claim.detail is not None:
        row["details"] = {k: claim.detail(r) for k, r in runs.items()}
    return row


def summarise(claim: Claim, group_runs: dict, corner_result: dict | None, corner_chosen: dict) -> dict:
    d = group_runs["default"]
    default = claim.value(d)
    rows = [_row(claim, prm.name, prm.kind, prm.default, prm.source, prm.changes, group_runs[prm.name])
            for prm in params_of(claim.group)]
    for name, values, source in (claim.measures(d) if claim.measures else []):  # other readings of the default run
        verdicts = {k: verdict(claim, v, d, OPEN) for k, v in values.items()}
        rows.append({"parameter": f"read as: {name}", "kind": OPEN, "default": "as the report", "source": source,
                     "changes": {}, "values": values, "verdicts": verdicts,
                     "reaches": [k for k, v in verdicts.items() if v in ("yes", CONSISTENT)]})
    out = {"id": claim.id, "claim": claim.text, "paper": claim.paper, "unit": claim.unit, "band": claim.band,
           "default": default, "default_verdict": claim.judge(default, d), "parameters": rows}
    if claim.detail is not None:
        out["default_detail"] = claim.detail(d)
    if corner_result is not None:
        v = claim.value(corner_result)
        out["best_corner"] = {"chosen": corner_chosen, "value": v, "verdict": claim.judge(v, corner_result)}
    candidates = [(f"{r['parameter']}: {k}", v, r["verdicts"][k]) for r in rows if r["kind"] == RANGE
                  for k, v in r["values"].items()]
    if corner_result is not None:
        candidates.append(("best corner", out["best_corner"]["value"], out["best_corner"]["verdict"]))
    yes = [c for c in candidates if c[2] == "yes"]
    by, v, verd = min(yes or candidates, key=lambda c: rel(c[1], claim.paper),
                      default=("default", default, out["default_verdict"]))
    if out["default_verdict"] == "yes" or (not yes and rel(default, claim.paper) <= rel(v, claim.paper)):
        by, v, verd = "default", default, out["default_verdict"]
    out["best_defensible"] = {"by": by, "value": v, "verdict": verd}
    out["reached_with_a_defensible_range_value"] = bool(yes)
    out["reached_only_by_an_open_choice"] = [f"{r['parameter']}: {k}" for r in rows if r["kind"] == OPEN
                                             for k in r["reaches"]]
    return out
