"""Runs the selected experiments one after the other, each isolated (a failure is recorded with
its error and the next one runs), prints a progress line per experiment and writes claims.json
and index.html."""

from __future__ import annotations

import json
import time
import traceback
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

from report import machine, offline_pool, page, printed
from report.registry import (
    CLAIM_KINDS,
    LOCK_WAIT_KEY,
    MEASURED,
    REPRODUCTION,
    VERDICTS,
    Context,
    Experiment,
    Figure,
    Finding,
    NotRun,
)


@dataclass
class Outcome:
    experiment: Experiment | None  # None: detached (as the offline worker returns it)
    status: str  # "ok", "failed", "not run"
    error: str = ""
    wall_s: float = 0.0
    findings: dict[str, Finding] = field(default_factory=dict)
    figures: list[Figure] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    numbers: dict = field(default_factory=dict)


def command_for(exp: Experiment, quick: bool) -> str:
    cmd = f"./testbed report --only {exp.id}" + (" --quick" if quick else "")
    return cmd + (f"  (itself: {exp.command})" if exp.command else "")


def run_one(exp: Experiment, out_dir: Path, quick: bool) -> Outcome:
    ctx = Context(out_dir=out_dir, quick=quick)
    t0 = time.perf_counter()
    try:
        findings = exp.run(ctx)
        _check_kinds(exp, findings)
        outcome = Outcome(exp, "ok", findings=dict(findings))
    except NotRun as exc:
        outcome = Outcome(exp, "not run", error=str(exc))
    except Exception as exc:  # noqa: BLE001 - one experiment's failure must not stop the others
        tb = traceback.format_exc(limit=6)
        outcome = Outcome(exp, "failed", error=f"{type(exc).__name__}: {exc}\n{tb}")
    outcome.wall_s = time.perf_counter() - t0
    outcome.figures, outcome.notes, outcome.numbers = ctx.figures, ctx.notes, ctx.numbers
    return outcome


def _check_kinds(exp: Experiment, findings: dict[str, Finding]) -> None:
    """A claim of the paper gets a verdict; only a question beyond the paper may get MEASURED."""
    for claim in exp.claims:
        f = findings.get(claim.id)
        if f is not None and f.verdict == MEASURED and not claim.beyond:
            raise ValueError(f"{claim.id} is a claim of the paper: it needs a verdict, not {MEASURED!r}")


def claim_rows(outcome: Outcome, quick: bool) -> list[dict]:
    """One row per paper claim of the experiment; a claim without a finding says why."""
    rows = []
    for claim in outcome.experiment.claims:
        row = {"id": claim.id, "experiment": outcome.experiment.id, "claim": claim.text, "paper": claim.paper,
               "beyond": claim.beyond, "kind": claim.kind, "command": command_for(outcome.experiment, quick)}
        finding = outcome.findings.get(claim.id)
        if finding is not None:
            row.update(testbed=finding.testbed, verdict=finding.verdict, reason=finding.reason,
                       measured=finding.measured)
        else:
            first_line = outcome.error.splitlines()[0] if outcome.error else "the experiment computed no finding for it"
            verdict = "not run" if outcome.status == "not run" else "failed"
            row.update(testbed="—", verdict=verdict, reason=first_line, measured={})
        rows.append(row)
    return rows


def summarise(rows: list[dict]) -> dict:
    """The headline: the verdicts of the reproductions only (claims compared with what the paper
    states); the questions beyond the paper as MEASURED (only when there are some). Consistency and
    input claims are counted apart (:func:`apart`)."""
    counts = Counter(r["verdict"] for r in rows if r["kind"] == REPRODUCTION and not r["beyond"])
    tally = {v: counts.get(v, 0) for v in (*VERDICTS, "failed", "not run")}
    measured = sum(r["verdict"] == MEASURED for r in rows)
    if measured:
        tally[MEASURED] = measured
    return tally


def apart(rows: list[dict]) -> dict[str, dict[str, int]]:
    """The verdicts of the claims of the paper that are not reproductions, per kind (consistency:
    the testbed against itself; input: a value the model is given), only the kinds present."""
    out: dict[str, dict[str, int]] = {}
    for kind in CLAIM_KINDS:
        counts = Counter(r["verdict"] for r in rows if r["kind"] == kind and kind != REPRODUCTION and not r["beyond"])
        if counts:
            out[kind] = {v: counts[v] for v in (*VERDICTS, "failed", "not run") if counts[v]}
    return out


def tally_text(summary: dict, kinds_apart: dict[str, dict[str, int]]) -> str:
    """"3 yes, 1 no; apart: consistency 2 yes, input 1 yes" (zero counts left out)."""
    head = ", ".join(f"{n} {v}" for v, n in summary.items() if n) or "no reproductions"
    rest = "; ".join(f"{kind} " + ", ".join(f"{n} {v}" for v, n in c.items()) for kind, c in kinds_apart.items())
    return head + (f"; apart: {rest}" if rest else "")


def run_report(experiments: list[Experiment], out_dir: Path, quick: bool, argv: list[str],
               progress: Callable[[str], None] | None = None, offline_on_two_cores: bool = False) -> dict:
    """Run ``experiments``: the offline ones first (on two cores with ``offline_on_two_cores``, see
    :mod:`report.offline_pool`), then the others in order; claims.json and index.html are rewritten
    after each one (a long run stopped half-way leaves a page of what finished, marked partial)."""
    progress = progress or (lambda line: print(line, flush=True))  # a line as it happens, also into a file
    out_dir.mkdir(parents=True, exist_ok=True)
    started = time.time()
    machine_before = machine.describe()
    outcomes: dict[int, Outcome] = {}
    data: dict = {}
    offline_phase: dict = {}  # filled when the offline experiments ran side by side (their wall times overlap)
    n = len(experiments)

    def announce(i: int) -> None:
        exp = experiments[i]
        progress(f"report: [{i + 1}/{n}] {exp.id} {exp.title} ({exp.kind}) …")

    def done(i: int, outcome: Outcome) -> None:
        outcome.experiment = experiments[i]
        rows = claim_rows(outcome, quick)
        tally = tally_text(summarise(rows), apart(rows)) if rows else ""
        detail = f": {outcome.error.splitlines()[0]}" if outcome.error else ""
        progress(f"report: [{i + 1}/{n}] {outcome.experiment.id} {outcome.status} in {outcome.wall_s:.1f} s"
                 f" ({tally or 'no claims'}){detail}")
        outcomes[i] = outcome
        write()

    def write() -> None:
        nonlocal data
        data = _data(outcomes, experiments, quick, argv, started, machine_before, offline_phase)
        (out_dir / "claims.json").write_text(json.dumps(data, indent=1, default=_jsonable))
        (out_dir / "index.html").write_text(page.render(data, out_dir))

    offline = [i for i, e in enumerate(experiments) if e.kind == "offline"]
    if offline_on_two_cores and offline_pool.worth_it(experiments, offline):
        progress(f"report: {len(offline)} offline experiments on two cores (this process and one worker) …")

        def detached(exp: Experiment) -> Outcome:
            announce(experiments.index(exp))
            return replace(run_one(exp, out_dir, quick), experiment=None)

        phase_started = time.time()
        offline_pool.run_offline(experiments, offline, detached, done,
                                 lambda exp, error: Outcome(None, "failed", error=error))
        offline_phase.update(two_cores=True, experiments=len(offline), wall_s=round(time.time() - phase_started, 1))
        write()
    for i, exp in enumerate(experiments):
        if i not in outcomes:
            announce(i)
            done(i, run_one(exp, out_dir, quick))
    return data


def _data(by_index: dict[int, Outcome], experiments: list[Experiment], quick: bool, argv: list[str], started: float,
          machine_before: dict, offline_phase: dict) -> dict:
    outcomes = [by_index[i] for i in sorted(by_index)]  # the registry's order, whatever order they finished in
    rows = [row for o in outcomes for row in claim_rows(o, quick)]
    return {
        "report_version": 1,
        "command": "python -m report " + " ".join(argv),
        "quick": quick,
        "complete": len(outcomes) == len(experiments),
        "pending": [e.id for i, e in enumerate(experiments) if i not in by_index],
        "wall_s": round(time.time() - started, 1),
        "offline_phase": offline_phase or None,
        "lock_wait_s": round(sum(sum(o.numbers.get(LOCK_WAIT_KEY, {}).values()) for o in outcomes), 1),
        "machine": {"before": machine_before, "after": machine.describe()},
        "headline": printed.headline(magnitudes := printed.table(rows)),  # each printed magnitude once
        "printed_magnitudes": magnitudes,
        "summary": summarise(rows),  # reproductions only
        "summary_apart": apart(rows),  # consistency and input claims, counted apart
        "experiments": [{
            "id": o.experiment.id, "title": o.experiment.title, "paper_figure": o.experiment.paper_figure,
            "kind": o.experiment.kind, "scope": o.experiment.scope, "status": o.status, "error": o.error,
            "wall_s": round(o.wall_s, 1), "command": command_for(o.experiment, quick),
            "time_scale": o.numbers.get("time_scale", "offline (no clock: as fast as the CPU allows)"),
            "figures": [{"name": f.name, "caption": f.caption, "png": f.png.name, "svg": f.svg.name} for f in o.figures],
            "notes": o.notes, "numbers": o.numbers,
        } for o in outcomes],
        "claims": rows,
    }


def _jsonable(x):
    if hasattr(x, "tolist"):
        return x.tolist()
    if isinstance(x, Path):
        return str(x)
    return repr(x)
