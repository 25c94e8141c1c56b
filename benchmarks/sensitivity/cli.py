"""The command of the claim sensitivity study (benchmarks/claim_sensitivity.py)."""

from __future__ import annotations

import argparse
import datetime
import json
import sys
import time
from pathlib import Path

from benchmarks.sensitivity import weak
from benchmarks.sensitivity.claims import ALIASES, CLAIMS, GROUPS
from benchmarks.sensitivity.common import commit, fmt, jsonable
from benchmarks.sensitivity.figures import figure, figure_f9_traces
from benchmarks.sensitivity.structure import KI_RULE
from benchmarks.sensitivity.study import RANGE_OPTIONS, corner, summarise, sweep_group

COMMAND = "PYTHONPATH=. nice -n 5 .venv/bin/python benchmarks/claim_sensitivity.py"


def _settings() -> dict:
    return {"f7": {"scr_range": weak.SCR_RANGE, "scr_range_if_not_stable_at_4": weak.F7_SCR_ABOVE,
                   "xtol": weak.F7_XTOL, "t_end_s": weak.F7_T_END, "ramp_rate_per_s": weak.RAMP_RATE,
                   "xtol_range_rows": RANGE_OPTIONS["F7"]["case.xtol"],
                   "note": "the full report's settings (4 s runs, bisection to 0.02) for the default, the structural "
                           "rows and the corner; the range rows' bisections to 0.05 (run time); a change of the SC's "
                           "parameters re-runs only the SC case, of the ViSC law's only the SDViSC case (the other "
                           "cases are the default's runs)"},
            "f9": {"t_end_s": weak.F9_T_END, "n_max": weak.F9_N_MAX, "n_max_ramp": weak.F9_N_MAX_RAMP},
            "faults": "the fault matrix (SLG/LLG x 0/15/50 ohm, R_f for the paper's value) on the default only; "
                      "range rows run the bolted SLG fault",
            "ki_rule": KI_RULE}


def main(argv: list[str], doc: str = "") -> int:
    ap = argparse.ArgumentParser(description=(doc or __doc__).split("\n\n")[0])
    ap.add_argument("--out", default="benchmarks/measured/claim-sensitivity")
    ap.add_argument("--date", default=datetime.date.today().isoformat())
    ap.add_argument("--only", default="", help="comma-separated groups: " + ", ".join(GROUPS))
    ap.add_argument("--commit", default=None, help="the code's commit, for the record (default: git rev-parse "
                    "HEAD here, marked if plant/, report/ or sdc_unit/ have uncommitted changes)")
    ap.add_argument("--redraw", action="store_true", help="only draw the figures again from the JSON in --out")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.redraw:
        data = json.loads((out / f"claim-sensitivity-{args.date}.json").read_text())
        for s in data["claims"]:
            figure(s, out / s["figure"])
        if "F9" in data["raw"]:
            figure_f9_traces(data["raw"]["F9"], out / f"f9d-traces-{args.date}.png")
        return 0
    only = {ALIASES.get(g, g) for g in args.only.split(",") if g}
    groups = [g for g in GROUPS if not only or g in only]
    t_start = time.time()

    def log(msg: str) -> None:
        print(f"[{time.time() - t_start:6.1f} s] {msg}", file=sys.stderr, flush=True)

    runs, result = {}, {"date": args.date, "commit": args.commit or commit(), "command": COMMAND,
                        "settings": _settings(), "claims": [], "raw": {}}
    for g in groups:
        runs[g] = sweep_group(g, log)
    for claim in CLAIMS:
        if claim.group not in runs:
            continue
        changes, chosen = corner(claim, runs[claim.group])
        corner_result = GROUPS[claim.group][0](changes) if changes else None
        log(f"{claim.id}: corner {chosen}")
        s = summarise(claim, runs[claim.group], corner_result, chosen)
        name = f"{claim.id.lower().replace('.', '')}-{args.date}.png"
        figure(s, out / name)
        s["figure"] = name
        result["claims"].append(s)
        print(f"{claim.id}: paper {claim.paper:g}, default {fmt(s['default'])} ({s['default_verdict']}), corner "
              f"{fmt(s.get('best_corner', {}).get('value'))}, best defensible {fmt(s['best_defensible']['value'])} "
              f"({s['best_defensible']['by']}), reached with a range value: "
              f"{s['reached_with_a_defensible_range_value']}, only by an open choice: "
              f"{s['reached_only_by_an_open_choice']}")
    if "F9" in runs:
        name = f"f9d-traces-{args.date}.png"
        figure_f9_traces(runs["F9"], out / name)
        next(c for c in result["claims"] if c["id"] == "F9.d")["figure_traces"] = name
    result["raw"] = {g: jsonable(r) for g, r in runs.items()}
    result["wall_s"] = round(time.time() - t_start, 1)
    path = out / f"claim-sensitivity-{args.date}.json"
    path.write_text(json.dumps(jsonable(result), indent=1) + "\n")
    log(f"wrote {path} and {len(result['claims'])} figures")
    return 0

