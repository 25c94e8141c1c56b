"""The SDN app's CPU per AK or heartbeat in a steady state, per thread: what its intake costs
(issue 32: "AK/heartbeat intake ≤ 30 µs each in the app").

Runs a scenario (default ``scenarios/all_visc_50.yaml``, every turbine a ViSC from 0.5 s) at time
scale ``--time-scale`` in a subprocess, waits until every turbine's path is acknowledged and
``--settle`` more wall seconds, then reads the app's threads' CPU (/proc/<pid>/task/<tid>/stat) and
its intake counters (``sdn_state.json`` → ``intake``: datagrams, wake-ups; ``threads``: the kernel ids
of its intake and timer threads) at the start and the end of a ``--window`` of wall seconds. Start-up
(50 requests, their paths and flow mods) is outside the window, which the whole-run figure of
``cpu_budget.py`` (``sdn_app_us_per_report``: all the app's CPU over all reports) includes.

Prints one JSON object: per thread CPU seconds in the window, the datagrams taken, µs per datagram
for the intake thread and µs per AK or heartbeat for the whole app. Needs root.

    python benchmarks/sdn_app_threads.py [--scenario scenarios/all_visc_50.yaml] [--time-scale 8]
        [--sdn-intake socket|packet_in] [--settle 3] [--window 20] [--out DIR]

``--sdn-intake packet_in`` runs the scenario with AKs and heartbeats as OpenFlow packet-ins (the
before of issue 32's intake socket): then no intake thread exists, and the whole app's CPU per
report (AKs and heartbeats counted by the controller: ``counters`` → ``ak_rx``, ``heartbeats``) is the
figure to compare.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import yaml
from scenario_runs import ROOT, finish, work_dir  # benchmarks/scenario_runs.py

from sdvisc.netns import CLOCK_TICKS, command_line, cpu_seconds_of


def thread_cpu_s(pid: int) -> dict[int, float]:
    """CPU seconds (user + system) of each thread of ``pid``."""
    out = {}
    for tid in os.listdir(f"/proc/{pid}/task"):
        seconds = cpu_seconds_of(f"{pid}/task/{tid}")
        if seconds is not None:
            out[int(tid)] = seconds
    return out


def app_pid(out_dir: Path, timeout_s: float = 120.0) -> int:
    deadline = time.time() + timeout_s
    marker = f"--config {out_dir}/sdn_config.json"
    while time.time() < deadline:
        for entry in os.listdir("/proc"):
            if entry.isdigit():
                cmd = command_line(entry) or ""
                if "-m sdn_app" in cmd and marker in cmd:
                    return int(entry)
        time.sleep(0.2)
    raise SystemExit("the SDN app did not start")


def state(out_dir: Path) -> dict:
    try:
        return json.loads((out_dir / "sdn_state.json").read_text())
    except (OSError, ValueError):
        return {}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenario", type=Path, default=ROOT / "scenarios" / "all_visc_50.yaml")
    ap.add_argument("--time-scale", default="8")
    ap.add_argument("--sdn-intake", choices=("socket", "packet_in"), default=None,
                    help="override the scenario's sdn.intake (a copy of the file in the work directory)")
    ap.add_argument("--settle", type=float, default=3.0, help="wall seconds after every path is acknowledged")
    ap.add_argument("--window", type=float, default=20.0, help="wall seconds measured")
    ap.add_argument("--out", type=Path)
    args = ap.parse_args(argv)
    work = work_dir(args.out, "sdvisc-app-threads-")
    out = work / "run"
    if args.sdn_intake:
        scenario = yaml.safe_load(args.scenario.read_text())
        scenario.setdefault("sdn", {})["intake"] = args.sdn_intake
        args.scenario = work / f"{args.scenario.stem}_{args.sdn_intake}.yaml"
        args.scenario.write_text(yaml.safe_dump(scenario, sort_keys=False))
    load0 = os.getloadavg()
    run = subprocess.Popen([sys.executable, "-m", "scenarios.cli", "run", str(args.scenario), "--out", str(out),
                            "--quiet", "--time-scale", args.time_scale], cwd=ROOT, stdout=subprocess.DEVNULL,
                           stderr=subprocess.DEVNULL)
    try:
        pid = app_pid(out)
        deadline = time.time() + 600
        while time.time() < deadline:
            st = state(out)
            t3 = st.get("tables", {}).get("T3", {})
            if t3 and all(v == "1/1" for v in t3.values()) and st.get("threads", {}).get("timer"):
                break
            if run.poll() is not None:
                raise SystemExit("the run ended before every path was acknowledged")
            time.sleep(0.2)
        time.sleep(args.settle)
        st0, cpu0, t0 = state(out), thread_cpu_s(pid), time.time()
        time.sleep(args.window)
        st1, cpu1, t1 = state(out), thread_cpu_s(pid), time.time()
        if run.poll() is not None:
            raise SystemExit("the run ended inside the window: give a longer scenario or a shorter --window")
    finally:
        code = run.wait(timeout=1200)
    names = {tid: name for name, tid in st1.get("threads", {}).items()}
    used = {tid: round(cpu1[tid] - cpu0.get(tid, 0.0), 3) for tid in cpu1}
    intake0, intake1 = st0.get("intake", {}), st1.get("intake", {})
    rx = intake1.get("rx", 0) - intake0.get("rx", 0)
    wakeups = intake1.get("wakeups", 0) - intake0.get("wakeups", 0)
    reports = sum(st1["counters"].get(k, 0) - st0["counters"].get(k, 0) for k in ("ak_rx", "heartbeats"))
    intake_s = used.get(st1["threads"].get("intake"), 0.0)
    result = {"benchmark": "sdn_app_threads", "scenario": args.scenario.name, "time_scale": float(args.time_scale),
              "window_wall_s": round(t1 - t0, 2), "run_exit": code, "load_before": load0,
              "intake": "packet_in" if not rx else "socket", "intake_datagrams": rx, "intake_wakeups": wakeups,
              "reports": reports,
              "cpu_s_per_thread": {names.get(tid, str(tid)): s for tid, s in sorted(used.items(), key=lambda x: -x[1]) if s},
              "clock_tick_s": 1 / CLOCK_TICKS,
              "intake_thread_us_per_datagram": round(intake_s / rx * 1e6, 1) if rx else None,
              "whole_app_us_per_report": round(sum(used.values()) / reports * 1e6, 1) if reports else None}
    return finish(result)


if __name__ == "__main__":
    sys.exit(main())
