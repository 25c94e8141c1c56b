"""The ``sdvisc`` command: ``run``, ``check``, ``clean``, ``pcap``, ``report``; the services on their own
(``sdc``, ``sdn-app``, ``owfcc``, ``gtnet-card``, ``owfcc-send``: scenarios/cli_services.py)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from scenarios.cli_services import add_parsers as add_service_parsers
from scenarios.summary import ADVICE_VERDICT, NOT_COUNTED
from scenarios.switch_links import SWITCH_LINK_KINDS
from scenarios.switch_ports import SWITCH_PORT_TYPES

DEFAULT_SCENARIO = Path(__file__).resolve().parent.parent / "scenarios" / "default.yaml"


def _cmd_check(args) -> int:
    from scenarios.loader import ScenarioError, load_scenario

    status = 0
    for path in args.files:
        try:
            sc = load_scenario(path)
        except ScenarioError as exc:
            print(exc, file=sys.stderr)
            status = 1
            continue
        duration = f"{sc.duration_s} s" if sc.duration_s is not None else "open-ended (--cli only)"
        print(f"{path}: ok ({sc.name}: {sc.topology.name}, {duration}, {len(sc.timeline)} events)")
    return status


def _time_scale(text: str) -> float | str:
    """A number or ``auto``; its range is the scenario schema's (checked with the file, scenarios.loader)."""
    if text == "auto":
        return text
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"the time scale is a number or 'auto', not {text!r}") from None


def _overrides(args) -> list:
    """The options that replace a key of the scenario: validated with it (scenarios.loader.Override)."""
    from scenarios.loader import Override

    given = [("--time-scale", ("time_scale",), args.time_scale, args.time_scale),
             ("--duration", ("duration_s",), args.duration, None if args.duration == float("inf") else args.duration),
             ("--switch-ports", ("switch_ports",), args.switch_ports, args.switch_ports),
             ("--switch-links", ("switch_links",), args.switch_links, args.switch_links),
             ("--cpu-split", ("cpu_split",), args.cpu_split, args.cpu_split == "on"),
             ("--pcap", ("capture", "pcap"), True if args.pcap else None, True),
             ("--plant", ("plant", "model"), args.plant, args.plant)]
    return [Override(option, "" if option == "--pcap" else f"{typed:g}" if isinstance(typed, float) else str(typed),
                     key, value)
            for option, key, typed, value in given if typed is not None]


def _cmd_run(args) -> int:
    from scenarios.loader import ScenarioError, load_scenario
    from scenarios.runner import RunError, run_scenario

    path = args.scenario or DEFAULT_SCENARIO
    try:
        scenario = load_scenario(path, _overrides(args))  # the options through the file's schema, before anything is built
    except ScenarioError as exc:
        print(exc, file=sys.stderr)
        return 1
    out = Path(args.out or Path("results") / scenario.name)
    problem = _session_options(args, scenario)
    if args.calibrate_from is not None:
        from scenarios.calibrate import CANDIDATES

        if scenario.time_scale != "auto" or args.calibrate_from not in CANDIDATES:
            problem = f"--calibrate-from needs time_scale auto and one of {', '.join(map(str, CANDIDATES))}"
    if args.recalibrate and scenario.time_scale != "auto":
        problem = "--recalibrate needs time_scale auto (--time-scale auto or the scenario's time_scale: auto)"
    if problem:
        print(f"sdvisc: {problem}", file=sys.stderr)
        return 1
    scaled = (" at the time scale calibrated before t = 0" if scenario.time_scale == "auto" else
              f" at time scale {scenario.time_scale:g} (virtual time)" if scenario.time_scale != 1 else "")
    print(f"sdvisc: running {path} -> {out}/{scaled}")
    try:
        summary = run_scenario(scenario, out, cli=args.cli, quiet=args.quiet, source=str(path),
                               cli_duration_s=args.cli_duration, web_port=args.web, calibrate_from=args.calibrate_from,
                               recalibrate=args.recalibrate)
    except RunError as exc:
        print(f"sdvisc: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("\nsdvisc: interrupted; network torn down, partial results in " + str(out), file=sys.stderr)
        return 130
    _print_result(summary, out)
    return 0


def _session_options(args, scenario) -> str | None:
    """The problem with an open-ended run, --cli-duration or --web, if any (--duration itself went
    through the scenario's checks)."""
    if scenario.duration_s is None and not args.cli:
        return "an open-ended run (duration_s: null or --duration inf) needs --cli: `exit` or --cli-duration ends it"
    if (args.cli_duration is not None or args.web is not None) and not args.cli:
        return "--cli-duration and --web are options of an interactive session (--cli)"
    return None


def _number(text: str) -> float:
    """A number (or inf); its range is the scenario schema's."""
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a number of seconds (or inf), not {text!r}") from None


def _seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a number of seconds (or inf), not {text!r}") from None
    if not value > 0:
        raise argparse.ArgumentTypeError("must be > 0")
    return value


def _print_result(summary: dict, out: Path) -> None:
    if summary["steps"] is None:  # a real card (scenarios/summary_turbines.py): its steps are its own
        print(f"sdvisc: {summary['scenario']}: {summary['duration_s']:g} s on the run's clock; the card's steps of "
              f"{summary['step_s'] * 1e3:.2f} ms: {NOT_COUNTED}; its side counted from "
              f"{(summary.get('peer') or {}).get('counted_at')}")
    else:
        print(f"sdvisc: {summary['scenario']}: {summary['steps']} steps of {summary['step_s'] * 1e3:.2f} ms, "
              f"{summary['late_steps']} late")
    for name, t in summary["turbines"].items():
        p = {k: "n/a" if v is None else v for k, v in t["packets"].items()}  # n/a: a real card counts nothing
        d = t["one_way_delay_ms"]["meas_to_sdc"] or {}
        one_way = f"one-way p50={d['p50']:.2f} ms" if d.get("p50") is not None else "one-way: not stamped"
        print(f"  {name}: meas_tx={p['meas_tx']} meas_rx_sdc={p['meas_rx_sdc']} ctrl_tx_sdc={p['ctrl_tx_sdc']} "
              f"ctrl_rx={p['ctrl_rx']} ak_tx={p['ak_tx']}  {one_way}{_by_sdc(t, summary)}")
    for sdc, part in summary.get("sdc_stats_partial", {}).items():
        print(f"sdvisc: note: {sdc}'s counts are those it had written by t = {part['as_of_t']} s ({part['why']})")
    conflicts = sorted({e["wt"] for e in summary.get("events", []) if e.get("type") == "ak_conflict"})
    if conflicts:  # two live AK streams for one turbine: someone on its LAN sends AKs in its name (docs/sdn.md)
        print(f"sdvisc: warning: {summary['sdn_counters'].get('ak_conflict', len(conflicts))} AK conflict(s) for "
              f"{', '.join(conflicts)}: a second AK stream in the turbine's name was ignored (forged? docs/sdn.md)")
    for sdc, why in summary.get("sdc_stats_missing", {}).items():
        print(f"sdvisc: note: {sdc} left no statistics ({why}): meas_rx_sdc and ctrl_tx_sdc leave out what it served")
    for r in summary["recoveries"]:
        took = f"{r['recovery_ms']:.1f} ms" if r['recovery_ms'] is not None else "not restored"
        print(f"  recovery {r['wt']} after {r['fault']['type']} ({r['cause']}): {took}")
    for name, code in summary.get("processes_exited_early", {}).items():
        print(f"sdvisc: warning: {name} exited early with code {code}; see {out}/{name}.log")
    cal = summary.get("time", {}).get("calibration")
    for name, t in summary["turbines"].items():
        rtt = t.get("round_trip_samples")
        if rtt:
            print(f"  {name}: MEAS->CTRL round trip within one sample for {rtt['within_one']:.1%} of answers "
                  f"(median {rtt['median']} samples)")
    if cal and cal.get("next_run_k"):  # auto: the run did not hold; the cache already holds the next k
        print(f"sdvisc: warning: {summary['advice'].split(ADVICE_VERDICT)[0]} (calibrated, did not hold); "
              f"the next run of this shape uses k = {cal['next_run_k']:g} (calibration cache {cal['cache_file']})")
    elif summary.get("advice"):
        print(f"sdvisc: warning: {summary['advice']}")
    elif cal:
        print(f"sdvisc: time scale {cal['time_scale']:g} ({'from the cache' if cal['source'] == 'cache' else 'calibrated'}) "
              "held: every turbine's answers within one sample for >= 99 % and under 1 % of the steps late")
    print(f"sdvisc: results in {out}/summary.json, events.jsonl, timeseries.csv")


def _by_sdc(turbine: dict, summary: dict) -> str:
    """`` [sdc1 a/b, sdc2 c/d]`` (MEAS received / CTRL sent by each) when more than one SDC counts,
    an SDC without statistics as ``n/a``; nothing for one SDC."""
    rows = {s: f"{r['meas_rx']}/{r['ctrl_tx']}" for s, r in turbine.get("per_sdc", {}).items()}
    rows |= {s: "n/a" for s in summary.get("sdc_stats_missing", {})}
    return "" if len(rows) < 2 else " [" + ", ".join(f"{s} {v}" for s, v in sorted(rows.items())) + "]"


def _cmd_clean(args) -> int:
    from host_tools.cleanup import clean

    clean(verbose=True)
    return 0


def _cmd_pcap(args) -> int:
    from host_tools.pcap import main as pcap_main

    return pcap_main(args.rest)


def _cmd_report(rest: list[str]) -> int:
    """``python -m report`` in a child process: the report stands a floor above scenarios/ (it runs
    scenarios through this CLI), so it is executed, never imported."""
    import os
    import subprocess

    root = str(Path(__file__).resolve().parent.parent)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in (root, os.environ.get("PYTHONPATH")) if p))
    return subprocess.call([sys.executable, "-m", "report", *rest], env=env)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["report"]:  # its options are the report's own (argparse's REMAINDER would stop at --only)
        return _cmd_report(argv[1:])
    parser = argparse.ArgumentParser(prog="sdvisc", description="SDViSC testbed: run and check scenarios; "
                                     "start one service on its own (docs/real-devices.md)")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("run", help="run a scenario on Mininet + Open vSwitch + os-ken")
    p.add_argument("scenario", nargs="?", help=f"scenario YAML (default {DEFAULT_SCENARIO.name})")
    p.add_argument("--out", help="output directory (default results/<scenario name>)")
    p.add_argument("--cli", action="store_true", help="interactive session: the Mininet CLI while the scenario runs; "
                   "the farm stays live after the timeline until you type exit (feedback on every action)")
    p.add_argument("--cli-duration", type=_seconds, default=None, metavar="S",
                   help="with --cli: end the session at t = S (simulated seconds), or at exit if earlier")
    p.add_argument("--duration", type=_number, default=None, metavar="S|inf",
                   help="override the scenario's duration_s (inf: open-ended, only with --cli)")
    p.add_argument("--web", type=int, nargs="?", const=8765, default=None, metavar="PORT",
                   help="with --cli: live view in a browser at http://127.0.0.1:PORT/ (default 8765; this machine only)")
    p.add_argument("--pcap", action="store_true", help="capture on the SDC host into the output directory")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.add_argument("--time-scale", type=_time_scale, default=None, metavar="K|auto",
                   help="wall seconds per simulated second (virtual time; overrides the scenario's time_scale); "
                        "auto: measure before t = 0 and take the smallest of 1, 2, 4 … 64 that holds")
    p.add_argument("--calibrate-from", type=float, default=None, metavar="K",
                   help="with auto: try K first (e.g. what an earlier run of the same shape chose), then smaller "
                        "ones while they hold, else larger: the same k found in fewer trials")
    p.add_argument("--recalibrate", action="store_true",
                   help="with auto: measure the time scale even if the calibration cache has this machine, code and "
                        "network shape (the cache: scenarios/calibration_cache.py)")
    p.add_argument("--switch-ports", choices=SWITCH_PORT_TYPES, default=None,
                   help="the switch side of every link (overrides the scenario's switch_ports): system, or AF_XDP "
                        "(afxdp: a PMD thread spins one core, hops ~10x cheaper; falls back to system where refused)")
    p.add_argument("--switch-links", choices=SWITCH_LINK_KINDS, default=None,
                   help="how switches are joined (overrides the scenario's switch_links): veth pairs, or patch ports "
                        "(every bridge of a path in one datapath pass; a failed link is removed)")
    p.add_argument("--plant", default=None, metavar="MODEL",
                   help="the plant model (overrides the scenario's plant.model, validated as that key): minimal, "
                        "full, or emt (the paper's comparison arrangement in EMT on DPsim, docs/plant.md)")
    p.add_argument("--cpu-split", choices=("on", "off"), default=None,
                   help="on: Open vSwitch's threads on a CPU of their own, the run's processes on the others "
                        "(overrides the scenario's cpu_split)")
    p.set_defaults(func=_cmd_run)
    p = sub.add_parser("check", help="validate scenario files (exit 1 naming file, line and key)")
    p.add_argument("files", nargs="+")
    p.set_defaults(func=_cmd_check)
    p = sub.add_parser("clean", help="remove what a crashed run left (processes, bridges, veths)")
    p.set_defaults(func=_cmd_clean)
    p = sub.add_parser("pcap", help="decode a testbed capture (GTNET-SKT messages)")
    p.add_argument("rest", nargs=argparse.REMAINDER)
    p.set_defaults(func=_cmd_pcap)
    p = sub.add_parser("report", help="reproduce the paper's Section IV: figures and claims in one page "
                                      "([--quick] [--only F4,C2] [--out DIR]; docs/report.md)")
    p.add_argument("rest", nargs=argparse.REMAINDER)
    add_service_parsers(sub)  # sdc, sdn-app, owfcc, gtnet-card, owfcc-send: one service outside Mininet
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())



