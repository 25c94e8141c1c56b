"""How often the live view of an interactive session updates (root; one smoke session per time scale).

Starts ``sdvisc run scenarios/smoke.yaml --cli --web PORT`` through a pty, waits for wt1_1's first
control packet, reads the page's server-sent events for ``--seconds`` wall seconds, types ``exit``
and prints one JSON object: per time scale the snapshots received, the wall gap between two
(p50, max; the issue's goal: at least every 200 ms) and how many carried a new plant status per
second (the plots' points).

    .venv/bin/python benchmarks/live_view.py [--time-scales 1 2] [--seconds 10]
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import sys
import tempfile
import time
import urllib.request

import pexpect
from scenario_runs import ROOT, machine  # benchmarks/scenario_runs.py


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def measure(time_scale: float, seconds: float, work: str) -> dict:
    port = free_port()
    child = pexpect.spawn(sys.executable, ["-m", "scenarios.cli", "run", "scenarios/smoke.yaml", "--cli", "--web", str(port),
                                           "--time-scale", f"{time_scale:g}", "--out", f"{work}/k{time_scale:g}"],
                          cwd=str(ROOT), encoding="utf-8", timeout=300, dimensions=(50, 200),
                          env=dict(os.environ, TERM="xterm"))
    try:
        child.expect("first control packet")
        stamps, t_sims = [], []
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/live", timeout=10) as stream:
            end = time.time() + seconds
            for line in stream:
                if line.startswith(b"data: "):
                    stamps.append(time.time())
                    t_sims.append(json.loads(line[6:])["t_sim"])
                if time.time() > end:
                    break
        child.sendline("exit")
        child.expect(pexpect.EOF)
    finally:
        child.close(force=True)
    gaps = sorted(b - a for a, b in zip(stamps, stamps[1:]))
    wall = stamps[-1] - stamps[0]
    new_status = sum(1 for a, b in zip(t_sims, t_sims[1:]) if b != a)
    return {"time_scale": time_scale, "snapshots": len(stamps), "wall_s": round(wall, 2),
            "gap_ms_p50": round(gaps[len(gaps) // 2] * 1e3, 1), "gap_ms_max": round(gaps[-1] * 1e3, 1),
            "new_plant_status_per_s": round(new_status / wall, 2), "session_exit_code": child.exitstatus}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--time-scales", type=float, nargs="+", default=[1.0, 2.0])
    parser.add_argument("--seconds", type=float, default=10.0)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as work:
        runs = [measure(k, args.seconds, work) for k in args.time_scales]
    print(json.dumps({"benchmark": "live_view", "runs": runs, "load_after": os.getloadavg()[0], "machine": machine()},
                     indent=1))


if __name__ == "__main__":
    main()
