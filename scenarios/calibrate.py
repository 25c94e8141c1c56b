"""``time_scale: auto``: measure on the built network what this run will cost, then pick the time scale.

Before t = 0 and before the SDN application starts, for each candidate k = 1, 2, 4, … 64 (smallest
first, stopping at the first that passes), the runner plays a pilot of the run itself at that k:

* **the plant**: this scenario's plant model, with its ViSC turbines in remote mode, stepped
  paced at k·Ts in the runner's process at the plant service's scheduling (SCHED_FIFO where
  allowed: :mod:`scenarios.calibration_probe`; the same model code the plant service runs), and each
  step one real MEAS per ViSC turbine (the model's own measurements, GTNET header, packed by the
  service's own :class:`plant.service.endpoint_tx.MeasPacker`) sent from that turbine's namespace; the step's compute (model, encoding, sending, reading the CTRLs) is timed and
  its busy fraction is cost / (k·Ts);
* **the SDC**: the real SDC service (:mod:`sdc_unit.pilot`: :class:`sdc_unit.service.SdcService`
  with the run's configuration, one instance per ViSC turbine) on the primary SDC's host answers
  every MEAS with its CTRL; its busy fraction is its process CPU over the trial's wall time;
* **the network**: MEAS and CTRL go through the switches along the shortest path the SDN app would
  install first (temporary OpenFlow rules, cookie :data:`PROBE_COOKIE`, removed and checked gone);
  the round trip MEAS sent → CTRL received is taken from the kernel's receive stamp.

A candidate passes (:func:`shortfalls`) when the plant and the SDC are each at most
:data:`BUSY_LIMIT` busy and every turbine's answer — its CTRL's kernel receive stamp, counted from
the start of the step that sent its MEAS — comes within :data:`ROUND_TRIP_LIMIT_STEPS` of a sample
at p99 (in simulated time, wall / k): the answer must reach the next step, which reads it first
thing; the pilot measures the step's own work before the send and the round trip itself, the SDC's
work included, and keeps a quarter of a sample for the load it leaves out (the run
then checks itself: its summary's ``advice`` when over 1 % of the answers came a sample late, and the
report runs such a run again at twice its k). A trial decided
by its last per cent of samples (:func:`borderline`) is extended once to twice its steps. Not measured: the SDN app's
and the OWFCC's CPU, the plant service's AKs, status files and recorder. How close each candidate
came (within one sample, late steps, share of the limit) is in ``candidates`` and each trial's
``closeness`` (:mod:`scenarios.calibration_report`).
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from functools import partial

import networkx as nx
import numpy as np

from plant.backend import close_backend
from plant.service.model import build_model
from scenarios import configs
from scenarios.calibration_probe import PilotSetup, plant_scheduling, probe
from scenarios.calibration_report import candidates, closeness
from scenarios.remote_process import RemoteProcess, popen_in
from sdvisc import rxstamp, wire
from sdvisc.config import write_config
from sdvisc.netns import cpu_seconds_of, udp_socket_in
from sdvisc.stats import delay_summary

CANDIDATES = (1, 2, 4, 8, 16, 32, 64)
BUSY_LIMIT = 0.5
ROUND_TRIP_LIMIT_STEPS = 0.75
"""The plant's step plus the MEAS → CTRL round trip p99 (the real SDC included) must fit in this
share of a sample. The answer must reach the next step, but the pilot leaves out part of the run's
load (the SDN app and its AKs, the plant service's own Python). First set to 0.5 when a pilot that
fitted 0.9 Ts (fault_4visc_network, k = 4) gave a run with 4.4 % of one turbine's answers a sample
late, before the plant's and the SDN app's disk writes left their paced loops (11–187 ms stalls).
Measured since (2026-12-01, farm, four SDViSCs; pilot = step + round-trip p99): runs at k = 16 of
F6 and F9's four-SDViSC case, whose pilots at 16 had taken 0.50–0.88 Ts in the reports (half a sample
sent them to 32), had 99.8–99.9 % of every turbine's answers within one sample; F1 at k = 8, whose
pilots at 8 took 0.79–0.94 Ts, had 98.6 and 99.5 %. A run that does not hold says so (summary
``advice``) and the report runs it again at twice its k. Until 2026-12-04 the pilot added the whole
step (its model, then every turbine's send) to each turbine's round trip; an answer is due a
sample after its own step began, so the sends after its own are not its delay — at 50 ViSCs they
were 1.5–2 ms of wall time per step, ~0.1 Ts at k = 16 (all_visc_50's pilot read 0.88 Ts and
chose 32; its run at 16 held)."""
VISC_SAMPLE_WALL_S = 130e-6
"""The whole emulation's CPU per ViSC sample at 50 ViSCs (plant, SDC, SDN app and ovs-vswitchd:
127–133 µs on this 2-core VM, benchmarks/measured/all-visc-50-issue32-2026-12-03.json): the first
candidate a calibration without a cached or given start tries (:func:`first_guess`)."""
PROBE_WALL_S = 1.5  # wall time per candidate …
MIN_PROBE_STEPS = 200  # … but at least this many steps (MEAS per turbine)
PROBE_COOKIE = 0x5D5CA1E
PROBE_COOKIE_TEXT = f"cookie={PROBE_COOKIE:#x}"
PROBE_PRIORITY = 65000


BORDERLINE_QUANTILES = (98.0, 99.5)
"""A trial whose worst turbine's p98 and p99.5 round trips lie either side of the limit is decided by
its last per cent of samples: at k = 16, 200 samples, where one stall of the machine (8–14 ms, every
turbine at once) is two samples, it picked k = 16 or 32 for the same scenario from run to run. Such
a trial is extended once by as many steps again and decided on all of them (p99 of twice the samples)."""


def borderline(rtt_ms: dict[str, list[float]], budget_wall_s: float) -> bool:
    """Whether the answer times ``rtt_ms`` (per turbine, wall ms from the start of the MEAS's step) are
    too close to ``budget_wall_s`` (:func:`answer_budget_s`) for a trial of this length to decide: the
    worst turbine's p98 within the budget and its p99.5 beyond it."""
    lists = [v for v in rtt_ms.values() if len(v)]
    if not lists:
        return False
    low, high = (max(float(np.percentile(v, q)) for v in lists) * 1e-3 for q in BORDERLINE_QUANTILES)
    return (low <= budget_wall_s) != (high <= budget_wall_s)


def answer_budget_s(period_s: float) -> float:
    """Wall seconds after its step began within which a MEAS's answer must arrive, at a sample period
    of ``period_s`` wall seconds: the share :data:`ROUND_TRIP_LIMIT_STEPS` of the period."""
    return ROUND_TRIP_LIMIT_STEPS * period_s


def shortfalls(k: float, step_s: float, plant_step_s: float, sdc_busy: float,
               worst_answer_p99_wall_s: float | None, lost: int = 0) -> list[str]:
    """Why time scale ``k`` is not enough (empty list: it is). ``plant_step_s``: wall seconds of
    compute per step; ``sdc_busy``: the SDC process's CPU per wall second; ``worst_answer_p99_wall_s``:
    the worst turbine's p99 of its CTRL's arrival after the start of its MEAS's step (wall s)."""
    period = k * step_s
    out = []
    if plant_step_s > BUSY_LIMIT * period:
        out.append(f"plant {plant_step_s / period:.0%} busy (limit {BUSY_LIMIT:.0%})")
    if sdc_busy > BUSY_LIMIT:
        out.append(f"SDC {sdc_busy:.0%} busy (limit {BUSY_LIMIT:.0%})")
    if worst_answer_p99_wall_s is not None and worst_answer_p99_wall_s > answer_budget_s(period):
        out.append(f"step start -> CTRL p99 {worst_answer_p99_wall_s / k * 1e3:.3f} ms simulated "
                   f"(limit {ROUND_TRIP_LIMIT_STEPS * step_s * 1e3:.3f} ms = {ROUND_TRIP_LIMIT_STEPS:g} Ts)")
    if lost:
        out.append(f"{lost} answers missing")
    return out


def search(trial, start: float | None = None, candidates: tuple = CANDIDATES) -> list[dict]:
    """Try candidates with ``trial(k) -> {"k", "ok", …}`` until the smallest passing one is known
    (the property is taken as monotonic in k): from the smallest upwards; or, from ``start`` (a k
    an earlier run of the same shape chose), downwards while it passes, else upwards — the same
    answer in two or three trials instead of up to seven."""
    ks = list(candidates)
    i = ks.index(start) if start in ks else 0
    trials = [trial(ks[i])]
    step = -1 if trials[0]["ok"] and i > 0 else 1
    if trials[0]["ok"] and i == 0:
        return trials
    j = i + step
    while 0 <= j < len(ks):
        trials.append(trial(ks[j]))
        if trials[-1]["ok"] != (step == -1):  # going down: stop at the first failure; up: at the first pass
            break
        j += step
    return trials


def first_guess(n_visc: int, step_s: float, candidates: tuple = CANDIDATES) -> float:
    """The candidate to try first for ``n_visc`` ViSC turbines: the largest at or below the k whose
    sample holds their CPU (``n_visc`` × :data:`VISC_SAMPLE_WALL_S`) on one core — two cores share
    it, so the guess errs low and :func:`search` goes up from it (all_visc_50: 8, then 16; two trials
    instead of five from k = 1)."""
    need = n_visc * VISC_SAMPLE_WALL_S / step_s
    return max([k for k in candidates if k <= need] or [candidates[0]])


def choose(trials: list[dict]) -> tuple[float, bool]:
    """The smallest passing k among ``trials`` (each ``{"k", "ok"}``), else the largest tried;
    and whether it passed."""
    passing = [t["k"] for t in trials if t["ok"]]
    if passing:
        return float(min(passing)), True
    return float(max(t["k"] for t in trials)), False


def pilot_flows(desc: dict, sdc_host: str, turbines: list[str]) -> dict[str, list[str]]:
    """Per OpenFlow switch, ``ovs-ofctl add-flows`` lines that carry MEAS from each turbine to
    ``sdc_host`` and CTRL back along shortest paths (hop count; a tree rooted at the SDC's switch)."""
    graph = nx.Graph()
    for link in desc["links"]:
        graph.add_edge(link["a"], link["b"], ports={link["a"]: link["a_port"], link["b"]: link["b_port"]})
    hosts = desc["hosts"]
    openflow = {name for name, s in desc["switches"].items() if s["openflow"]}
    root = hosts[sdc_host]["switch"]
    graph.add_node(root)
    paths = nx.single_source_shortest_path(graph, root)
    flows: dict[str, set[str]] = {}
    head = f"{PROBE_COOKIE_TEXT},priority={PROBE_PRIORITY},udp"

    def add(switch: str, match: str, port: int) -> None:
        if switch in openflow:
            flows.setdefault(switch, set()).add(f"{head},{match},actions=output:{port}")

    to_sdc = f"nw_dst={hosts[sdc_host]['ip']},tp_dst={wire.PORT_SDC}"
    add(root, to_sdc, hosts[sdc_host]["port"])
    for wt in turbines:
        edge = hosts[wt]["switch"]
        if edge not in paths:
            raise ValueError(f"calibration: no path from {wt} to {sdc_host}")
        path = paths[edge][::-1]  # turbine's switch … SDC's switch
        to_wt = f"nw_dst={hosts[wt]['ip']},tp_dst={hosts[wt].get('udp_port', wire.PORT_TURBINE)}"
        add(edge, to_wt, hosts[wt]["port"])
        for a, b in zip(path, path[1:]):
            ports = graph.edges[a, b]["ports"]
            add(a, to_sdc, ports[a])
            add(b, to_wt, ports[b])
    return {sw: sorted(lines) for sw, lines in flows.items()}


class Calibration:
    """Runs the pilot on ``run``'s built network (see the module docstring)."""

    def __init__(self, run) -> None:
        self.run = run
        sc = run.scenario
        self.step_s = sc.step_s
        hosts = run.desc["hosts"]
        self.turbines = [wt for wt in sc.turbines_named() if wt in hosts]
        self.sdc_host, self.sdc_id, self.sdc_role = configs.sdcs(sc)[0]
        self.flows = pilot_flows(run.desc, self.sdc_host, self.turbines) if self.turbines else {}

    # ------------------------------------------------------------------ set-up and teardown
    def _ofctl(self, args: list[str], stdin: str | None = None) -> str:
        res = self.run.ovs_tool("ovs-ofctl", ["-O", "OpenFlow13", *args], switch=args[1], stdin=stdin)  # where it is
        if res.returncode != 0:
            raise RuntimeError(f"ovs-ofctl {' '.join(args)}: {res.stderr.strip()}")
        return res.stdout

    def _model(self, setup: PilotSetup) -> bool:
        """The plant model in ``setup``; returns whether the plant service steps at real-time priority."""
        run, sc = self.run, self.run.scenario
        pids = {n: None for n, h in run.desc["hosts"].items() if h["role"] == "turbine"}
        cfg = configs.plant_config(sc, run.desc, str(run.out), pids, {"time_scale": 1.0})
        names = [t.name for t in cfg.turbines]
        setup.model, indices = build_model(cfg, names)
        setup.indices = [indices[names.index(wt)] for wt in self.turbines]
        for i in setup.indices:
            setup.model.set_mode(i, "remote")
        return cfg.realtime_priority

    def _start_pilot(self, setup: PilotSetup):
        run = self.run
        cfg = configs.sdc_config(run.scenario, run.desc, str(run.out), self.sdc_id, self.sdc_role, {"time_scale": 1.0})
        cfg_path = write_config(cfg, run.out / "calibration_sdc_config.json")
        ready = run.out / "calibration_sdc.json"
        ready.unlink(missing_ok=True)
        args = [sys.executable, "-m", "sdc_unit.pilot", "--config", str(cfg_path), "--ready", str(ready),
                "--serve", ",".join(str(setup.wids[wt]) for wt in self.turbines)]
        host = run.net.get(self.sdc_host)
        log = open(run.out / "calibration_sdc.log", "w")  # noqa: SIM115 - the pilot's
        pilot = popen_in(host, args, env=dict(os.environ), pidfile=run.out / "calibration_sdc.pid",
                         stdout=subprocess.DEVNULL, stderr=log)  # (on its server across servers)
        deadline = time.time() + 60
        while not ready.exists():
            if pilot.poll() is not None or time.time() > deadline:
                raise RuntimeError(f"calibration: the SDC pilot on {self.sdc_host} did not start; see "
                                   f"{run.out}/calibration_sdc.log")
            time.sleep(0.02)
        setup.pilot_cpu_s = pilot.cpu_seconds if isinstance(pilot, RemoteProcess) else partial(cpu_seconds_of, pilot.pid)
        return pilot

    def measure(self) -> dict:
        """Pilot candidates from the run's ``calibrate_from`` or else :func:`first_guess` (see
        :func:`search`); returns the calibration for ``summary.json``."""
        run = self.run
        hosts = run.desc["hosts"]
        setup = PilotSetup(hosts[self.sdc_host]["ip"], self.turbines,
                           {wt: wire.turbine_id(hosts[wt]["cluster"], hosts[wt]["number"]) for wt in self.turbines},
                           step_s=self.step_s)
        started = time.time()
        pilot = None
        trials: list[dict] = []
        try:
            for sw, lines in self.flows.items():
                self._ofctl(["add-flows", sw, "-"], "\n".join(lines) + "\n")
            if self.turbines:
                pilot = self._start_pilot(setup)
                for wt in self.turbines:
                    sock = udp_socket_in(run.net.get(wt).pid, hosts[wt]["ip"], hosts[wt].get("udp_port", wire.PORT_TURBINE))
                    rxstamp.enable(sock)
                    setup.socks[wt] = sock
            realtime = self._model(setup)
            start = getattr(run, "calibrate_from", None) or first_guess(len(self.turbines), self.step_s)
            with plant_scheduling(realtime) as setup.scheduling:  # as the plant service steps
                trials = search(lambda k: self._trial(setup, k), start)
        finally:
            close_backend(getattr(setup, "model", None))  # (the EMT backend stops its DPsim simulation)
            for sock in setup.socks.values():
                sock.close()
            if pilot is not None:
                pilot.terminate()
                try:
                    pilot.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    pilot.kill()
            for sw in self.flows:
                self._ofctl(["del-flows", sw, f"{PROBE_COOKIE_TEXT}/-1"])
            left = [sw for sw in self.flows if PROBE_COOKIE_TEXT in self._ofctl(["dump-flows", sw])]
            if left:
                raise RuntimeError(f"calibration: pilot rules still on {left} after removing them")
        k, met = choose(trials)
        return {"time_scale": k, "met": met, "started_from": start if self.turbines else None,
                "turbines": self.turbines, "sdc": self.sdc_host,
                "limits": {"busy": BUSY_LIMIT, "answer_p99_sim_ms": ROUND_TRIP_LIMIT_STEPS * self.step_s * 1e3},
                "candidates": candidates(trials), "plant_scheduling": setup.scheduling, "trials": trials, "wall_s": round(time.time() - started, 2),
                "plant_model": run.scenario.plant.model}

    # ------------------------------------------------------------------ one candidate
    def _trial(self, setup: PilotSetup, k: float) -> dict:
        period = k * self.step_s
        steps = max(MIN_PROBE_STEPS, int(PROBE_WALL_S / period))
        rtt: dict[str, list[float]] = {wt: [] for wt in setup.turbines}
        back: dict[str, list[float]] = {wt: [] for wt in setup.turbines}
        answer: dict[str, list[float]] = {wt: [] for wt in setup.turbines}  # CTRL after its step began, wall ms
        setup.sent.clear()
        cpu0, wall0 = setup.pilot_cpu_s(), time.time()
        plant_s, lateness = probe(setup, period, steps, (rtt, back, answer))
        extended = False
        if not shortfalls(k, self.step_s, float(np.mean(plant_s)), 0.0, None) and borderline(
                answer, answer_budget_s(period)):
            more_s, more_late = probe(setup, period, steps, (rtt, back, answer))
            plant_s, lateness = np.concatenate([plant_s, more_s]), np.concatenate([lateness, more_late])
            steps, extended = 2 * steps, True
        sdc_busy = (setup.pilot_cpu_s() - cpu0) / (time.time() - wall0)
        per_turbine = {wt: {"round_trip_ms": delay_summary(rtt[wt]), "to_turbine_ms": delay_summary(back[wt]),
                            "after_step_start_ms": delay_summary(answer[wt]), "missing": steps - len(rtt[wt])}
                       for wt in setup.turbines}
        worst = max((np.percentile(answer[wt], 99) for wt in setup.turbines if answer[wt]), default=None)
        missing = sum(r["missing"] for r in per_turbine.values())
        plant_cost = float(np.mean(plant_s))
        why_not = shortfalls(k, self.step_s, plant_cost, sdc_busy, None if worst is None else worst * 1e-3,
                             missing if missing > 0.01 * steps * max(1, len(setup.turbines)) else 0)
        return {"k": k, "steps": steps, "extended": extended, "ok": not why_not, "why_not": why_not,
                "plant_step_us": {"mean": round(plant_cost * 1e6, 1), "p99": round(float(np.percentile(plant_s, 99)) * 1e6, 1)},
                "plant_busy": round(plant_cost / period, 3), "sdc_busy": round(sdc_busy, 3),
                "answer_p99_sim_ms": None if worst is None else round(worst / k, 4),
                "closeness": closeness(answer, steps, period, answer_budget_s(period), lateness,
                                       None if worst is None else worst * 1e-3),
                "per_turbine_wall": per_turbine}
