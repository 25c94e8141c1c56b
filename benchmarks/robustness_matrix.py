"""Robustness matrix (issue 42): shipped scenarios × {their own time scale, ``--time-scale auto``} ×
{to the end, SIGINT at a random moment, SIGTERM at a random moment}. Per cell: the exit status, a
summary or one clear line on stderr, no traceback, no hang (a timeout), nothing left behind
(processes, namespaces, bridges, veths, servers: host_tools.cleanup.leftovers). JSON out.

    python -m benchmarks.robustness_matrix [--scenarios smoke,link_failure_dr,paper/f3_voltage_step] [--seed 1]
        [--sample-others] [--out benchmarks/measured/robustness-matrix-DATE.json]

``--scenarios all`` is every shipped scenario (scenarios/ and scenarios/paper/). The whole product
(42 scenarios × 6 cells, 1-3 min a cell here) takes 4-8 h on this machine, so ``--sample-others``
runs all six cells of the scenarios named by ``--full`` (default: the four above) and one cell,
drawn with the seed, of every other shipped scenario: every scenario and every kind of cell is
covered in about an hour.

Each cell holds the network lock (/tmp/sdvisc-net.lock) while it runs, unless
SDVISC_NETWORK_LOCK_HELD=1. A signal is sent at a random moment between 1 s after the start and
the run's expected end (SIGINT to the process group, as Ctrl-C does; SIGTERM to the process).
"""

from __future__ import annotations

import argparse
import fcntl
import json
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from datetime import date
from pathlib import Path

from host_tools.child_signals import default_signals

ROOT = Path(__file__).resolve().parents[1]
LOCK = "/tmp/sdvisc-net.lock"
HANG_S = 600.0
"""A cell that has not ended this long after its start (or 120 s after its signal) hangs."""
DEFAULT = ("smoke", "link_failure_dr", "external_peer", "cluster_smoke")
ENDINGS = ("end", "SIGINT", "SIGTERM")


def leftovers() -> dict:
    from host_tools.cleanup import leftovers as left

    return {k: v for k, v in left().items() if v}


def expected_wall_s(path: Path, auto: bool) -> float:
    import yaml

    data = yaml.safe_load(path.read_text())
    k = data.get("time_scale", 1)
    auto = auto or k == "auto"  # (a calibration before t = 0: about 30-60 s here)
    return (40.0 if auto else 5.0) + float(data.get("duration_s") or 5.0) * (4.0 if auto else float(k))


def cell(path: Path, auto: bool, ending: str, rng: random.Random) -> dict:
    out = Path(tempfile.mkdtemp(prefix="sdvisc-matrix-"))
    cmd = [sys.executable, "-m", "scenarios.cli", "run", str(path), "--out", str(out), "--quiet"]
    cmd += ["--time-scale", "auto"] if auto else []
    started = time.monotonic()
    # (default dispositions: started from a background job the matrix ignores SIGINT, and so would the run)
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True, preexec_fn=default_signals)
    result = {"scenario": str(path.relative_to(ROOT / "scenarios").with_suffix("")), "time_scale": "auto" if auto else "own", "ending": ending}
    deadline = started + HANG_S
    if ending != "end":
        at = rng.uniform(1.0, 0.9 * expected_wall_s(path, auto))  # set-up, calibration or the run itself
        result["signal_after_s"] = round(at, 2)
        while proc.poll() is None and time.monotonic() < started + at:
            time.sleep(0.05)
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGINT) if ending == "SIGINT" else proc.send_signal(signal.SIGTERM)
            deadline = time.monotonic() + 120
        else:
            result["ended_before_signal"] = True
    try:
        stdout, stderr = proc.communicate(timeout=max(1.0, deadline - time.monotonic()))
        result["hang"] = False
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        stdout, stderr = proc.communicate(timeout=30)
        result["hang"] = True
    result.update(returncode=proc.returncode, wall_s=round(time.monotonic() - started, 1),
                  traceback="Traceback (most recent call last)" in stderr + stdout,
                  summary=(out / "summary.json").exists(),
                  stderr_tail=stderr.strip().splitlines()[-3:])
    result["clear"] = result["summary"] or (len(stderr.strip().splitlines()) >= 1 and not result["traceback"])
    result["leftovers"] = leftovers()
    if result["leftovers"]:  # the next cell must start clean; what was left is recorded above
        from host_tools.cleanup import clean

        clean()
    # refused before anything was built (e.g. auto with an emulated peer): one clear line, status 1
    result["refused"] = result["returncode"] == 1 and not result["summary"]
    result["ok"] = (not result["hang"] and not result["traceback"] and not result["leftovers"] and result["clear"]
                    and (result["returncode"] in (0, 1) if ending == "end" else result["returncode"] in (0, 1, 2, 130)))
    return result


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.robustness_matrix", description=__doc__.splitlines()[0])
    p.add_argument("--scenarios", default=",".join(DEFAULT), help="comma-separated names under scenarios/, e.g. paper/f3_voltage_step (all: every one)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--sample-others", action="store_true",
                   help="all cells of --full, one seeded cell of every other shipped scenario")
    p.add_argument("--full", default=",".join(DEFAULT), help="with --sample-others: scenarios that get every cell")
    p.add_argument("--out", default=str(ROOT / "benchmarks" / "measured" / f"robustness-matrix-{date.today()}.json"))
    args = p.parse_args(argv)
    shipped = [str(q.relative_to(ROOT / "scenarios").with_suffix("")) for q in sorted((ROOT / "scenarios").rglob("*.yaml"))]
    names = shipped if args.scenarios == "all" or args.sample_others else args.scenarios.split(",")
    rng = random.Random(args.seed)
    every_cell = [(auto, ending) for auto in (False, True) for ending in ENDINGS]
    plan = []
    for name in names:
        if args.sample_others and name not in args.full.split(","):
            plan.append((name, [rng.choice(every_cell)]))
        else:
            plan.append((name, every_cell))
    cells = []
    for name, name_cells in plan:
        for auto, ending in name_cells:
            with open(LOCK, "a") as lock:
                if os.environ.get("SDVISC_NETWORK_LOCK_HELD") != "1":
                    fcntl.flock(lock, fcntl.LOCK_EX)
                c = cell(ROOT / "scenarios" / f"{name}.yaml", auto, ending, rng)
            cells.append(c)
            print(json.dumps({k: c[k] for k in ("scenario", "time_scale", "ending", "returncode", "wall_s", "ok")}),
                  flush=True)
            Path(args.out).write_text(json.dumps(
                {"seed": args.seed, "cells": cells,
                 "plan": {"sample_others": args.sample_others, "scenarios": len(plan),
                          "cells_planned": sum(len(planned) for _, planned in plan)},
                 "totals": {"cells": len(cells), "ok": sum(c["ok"] for c in cells),
                            "tracebacks": sum(c["traceback"] for c in cells), "hangs": sum(c["hang"] for c in cells),
                            "with_leftovers": sum(bool(c["leftovers"]) for c in cells)}}, indent=1))
    return 0 if all(c["ok"] for c in cells) else 1


if __name__ == "__main__":
    sys.exit(main())
