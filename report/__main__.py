"""``python -m report [--quick] [--only F4,C2] [--out DIR]``: run the paper's experiments and write
DIR/index.html, claims.json and the figures (PNG and SVG). Exit status 0 when every selected
experiment ran (whatever its verdicts), 1 when one failed, 2 on a bad option."""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

from report import net_arrangement, network_runs
from report.catalogue import EXPERIMENTS, QUICK_NETWORK
from report.registry import Context, Experiment, NotRun, select
from report.run import run_report, tally_text
from scenarios.switch_ports import SWITCH_PORT_TYPES

DEFAULT_OUT = Path("results/report")


def parse(argv: list[str]) -> argparse.Namespace:
    ap = argparse.ArgumentParser(prog="python -m report", description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="coarser searches and shorter windows (minutes, not tens)")
    ap.add_argument("--only", default=None, metavar="IDS",
                    help="comma-separated experiments, e.g. F4,C2 (known: " + ",".join(e.id for e in EXPERIMENTS) + ")")
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT, help=f"output directory (default {DEFAULT_OUT}/)")
    ap.add_argument("--switch-ports", choices=SWITCH_PORT_TYPES, default="afxdp",
                    help="the switch side of every link in the network runs (default afxdp: hops ~10x cheaper "
                         "than system ports, one core spun by Open vSwitch during each run; falls back to system "
                         "where AF_XDP is refused; docs/report.md, Time)")
    ap.add_argument("--net-arrangement", choices=net_arrangement.ARRANGEMENTS, default=net_arrangement.ONSHORE,
                    help="the SDViSC(s) of F3net-F7net: onshore (default: the paper's comparison arrangement, one "
                         "40 MVA SDViSC at the onshore PCC, host wt6_1) or cluster3 (four SDViSCs of cluster 3, "
                         "scenarios/paper/*_cluster3.yaml); report/net_arrangement.py")
    ap.add_argument("--list", action="store_true", help="list the experiments and their claims, run nothing")
    return ap.parse_args(argv)


def quick_network_subset(exp: Experiment) -> Experiment:
    """``--quick`` without ``--only``: of the cyber-in-the-loop experiments only QUICK_NETWORK run (each
    network run costs ~20 s of set-up plus k times its simulated window); the others say so ("not
    run") and run with ``--only`` (also with ``--quick``) or in the full report."""
    if exp.kind != "cyber" or exp.id in QUICK_NETWORK:
        return exp

    def skipped(ctx: Context) -> dict:
        raise NotRun(f"--quick runs {', '.join(QUICK_NETWORK)} of the network experiments; this one runs in the "
                     f"full report or with --only {exp.id} [--quick]")
    return replace(exp, run=skipped)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    args = parse(argv)
    try:
        chosen = select(EXPERIMENTS, args.only)
    except ValueError as exc:
        print(f"report: {exc}", file=sys.stderr)
        return 2
    if args.list:
        for e in chosen:
            print(f"{e.id:3} {e.kind:8} {e.paper_figure:24} {e.title}")
            for c in e.claims:
                print(f"      {c.id:6} {c.text} [paper: {c.paper}; {c.kind}]")
        return 0
    network_runs.SWITCH_PORTS = args.switch_ports
    net_arrangement.choose(args.net_arrangement)
    if args.quick and not args.only:
        chosen = [quick_network_subset(e) for e in chosen]
    data = run_report(chosen, args.out, args.quick, argv, offline_on_two_cores=True)
    print(f"report: {args.out}/index.html, claims.json ({data['wall_s']} s; reproductions: "
          + tally_text(data["summary"], data["summary_apart"]) + ")")
    return 1 if any(e["status"] == "failed" for e in data["experiments"]) else 0


if __name__ == "__main__":
    sys.exit(main())
