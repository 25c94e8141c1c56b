"""``time_scale: auto``: measure on the built network what this run will cost, then pick the time scale.

Before t = 0 and before the SDN application starts, for each candidate k = 1, 2, 4, … 64 (smallest
first, stopping at the first that passes), the runner plays one probe of the run itself at that k:

* **the plant**: this scenario's plant model, with its ViSC turbines in remote mode, stepped
  paced at k·Ts in the runner's process (the same model code the plant service runs), timed per
  step; its busy fraction is step cost / (k·Ts);
* **the SDC**: one :class:`sdc_unit.bank.ControllerBank` round for the scenario's ViSC turbines
  fed with the plant's own measurements, timed the same way;
* **the network**: every step, one probe the size of a MEAS from each ViSC turbine's namespace to
  an echo process on the primary SDC's host and back (:mod:`sdvisc.probe`), along the shortest
  path the SDN app would install first (temporary OpenFlow rules, cookie :data:`PROBE_COOKIE`,
  removed afterwards); one-way delays from kernel receive stamps, both directions.

The network carries the run's packet rate at that k while the plant and the SDC load the CPU as
they will, so the probe sees the contention of the run, not an idle machine. A candidate passes
(:func:`shortfalls`) when the plant and the SDC are each at most :data:`BUSY_LIMIT` busy and every
turbine's one-way delay p99, in simulated time (wall / k), is at most :data:`ONE_WAY_LIMIT_STEPS`
× Ts (so MEAS → CTRL fits in one sample, with the margin that constant explains). Not measured: the SDN app's and the OWFCC's CPU (a few
% of a core at these rates), the plant's socket work for AKs, and the recorder.
"""

from __future__ import annotations

import subprocess
import sys
import time
from dataclasses import dataclass, field

import networkx as nx
import numpy as np

from scenarios import configs
from sdvisc import probe, wire
from sdvisc.netns import udp_socket_in
from sdvisc.stats import delay_summary
from sdvisc.vocabulary import FILTER_R_F_PU, FILTER_X_F_PU, MEAS_FIELDS

CANDIDATES = (1, 2, 4, 8, 16, 32, 64)
BUSY_LIMIT = 0.5
ONE_WAY_LIMIT_STEPS = 0.25
"""Probe one-way p99 limit in samples (simulated time). The issue asks for Ts/2 so that MEAS → CTRL fits
in one sample; a probe loads the machine less than the run's services do (measured on
fault_4visc_network at k = 4: probe p99 0.32 ms, the run's own MEAS/CTRL p99 0.71/0.94 ms simulated,
26 % of the answers late by a sample, four converter trips), so the limit is half of that."""
PROBE_WALL_S = 1.5  # wall time per candidate …
MIN_PROBE_STEPS = 200  # … but at least this many steps (probes per turbine)
PROBE_COOKIE = 0x5D5CA1E
PROBE_COOKIE_TEXT = f"cookie={PROBE_COOKIE:#x}"
PROBE_PRIORITY = 65000


def shortfalls(k: float, step_s: float, plant_step_s: float, sdc_round_s: float,
               worst_one_way_p99_wall_s: float | None, lost: int = 0) -> list[str]:
    """Why time scale ``k`` is not enough (empty list: it is). Costs are wall seconds per step."""
    period = k * step_s
    out = []
    if plant_step_s > BUSY_LIMIT * period:
        out.append(f"plant {plant_step_s / period:.0%} busy (limit {BUSY_LIMIT:.0%})")
    if sdc_round_s > BUSY_LIMIT * period:
        out.append(f"SDC {sdc_round_s / period:.0%} busy (limit {BUSY_LIMIT:.0%})")
    if worst_one_way_p99_wall_s is not None and worst_one_way_p99_wall_s / k > ONE_WAY_LIMIT_STEPS * step_s:
        out.append(f"one-way p99 {worst_one_way_p99_wall_s / k * 1e3:.3f} ms simulated "
                   f"(limit {ONE_WAY_LIMIT_STEPS * step_s * 1e3:.3f} ms = {ONE_WAY_LIMIT_STEPS:g} Ts)")
    if lost:
        out.append(f"{lost} probes lost")
    return out


def choose(trials: list[dict]) -> tuple[float, bool]:
    """The smallest passing k among ``trials`` (each ``{"k", "ok"}``), else the largest tried;
    and whether it passed."""
    passing = [t["k"] for t in trials if t["ok"]]
    if passing:
        return float(min(passing)), True
    return float(max(t["k"] for t in trials)), False


@dataclass
class ProbeSetup:
    """What one calibration talks to: the ViSC turbines' sockets, the SDC's echo, the model."""

    sdc_host: str
    sdc_ip: str
    turbines: list[str]
    wids: dict[str, int]
    socks: dict = field(default_factory=dict)
    model: object = None
    indices: list[int] = field(default_factory=list)
    bank: object = None


def probe_flows(desc: dict, sdc_host: str, turbines: list[str]) -> dict[str, list[str]]:
    """Per OpenFlow switch, ``ovs-ofctl add-flows`` lines that carry probes from each turbine to
    ``sdc_host`` and back along shortest paths (hop count; a tree rooted at the SDC's switch)."""
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

    to_sdc = f"nw_dst={hosts[sdc_host]['ip']},tp_dst={probe.PROBE_PORT}"
    add(root, to_sdc, hosts[sdc_host]["port"])
    for wt in turbines:
        edge = hosts[wt]["switch"]
        if edge not in paths:
            raise ValueError(f"calibration: no path from {wt} to {sdc_host}")
        path = paths[edge][::-1]  # turbine's switch … SDC's switch
        to_wt = f"nw_dst={hosts[wt]['ip']},tp_src={probe.PROBE_PORT}"
        add(edge, to_wt, hosts[wt]["port"])
        for a, b in zip(path, path[1:]):
            ports = graph.edges[a, b]["ports"]
            add(a, to_sdc, ports[a])
            add(b, to_wt, ports[b])
    return {sw: sorted(lines) for sw, lines in flows.items()}


class Calibration:
    """Runs the probes on ``run``'s built network (see the module docstring)."""

    def __init__(self, run) -> None:
        self.run = run
        sc = run.scenario
        self.step_s = sc.step_s
        hosts = run.desc["hosts"]
        self.turbines = [wt for wt in sc.turbines_named() if wt in hosts]
        self.sdc_host = configs.sdcs(sc)[0][0]
        self.flows = probe_flows(run.desc, self.sdc_host, self.turbines) if self.turbines else {}

    # ------------------------------------------------------------------ set-up and teardown
    def _ofctl(self, args: list[str], stdin: str | None = None) -> str:
        res = subprocess.run(["ovs-ofctl", "-O", "OpenFlow13", *args], input=stdin, capture_output=True, text=True)
        if res.returncode != 0:
            raise RuntimeError(f"ovs-ofctl {' '.join(args)}: {res.stderr.strip()}")
        return res.stdout

    def _model(self, setup: ProbeSetup) -> None:
        from plant.service import build_model  # noqa: PLC0415 - the plant model is heavy; only auto needs it
        from sdc_unit.bank import ControllerBank  # noqa: PLC0415

        run, sc = self.run, self.run.scenario
        pids = {n: None for n, h in run.desc["hosts"].items() if h["role"] == "turbine"}
        cfg = configs.plant_config(sc, run.desc, str(run.out), pids, {"time_scale": 1.0})
        names = [t.name for t in cfg.turbines]
        model, indices = build_model(cfg, names)
        setup.model = model
        setup.indices = [indices[names.index(wt)] for wt in self.turbines]
        for i in setup.indices:
            model.set_mode(i, "remote")
        if setup.indices:
            setup.bank = ControllerBank(len(setup.indices), sc.step_s, sc.sdc.method, sc.sdc.dtype)
            setup.bank.warm_up()
            for slot in range(len(setup.indices)):
                setup.bank.start(slot, {"mask": 0})

    def measure(self) -> dict:
        """Probe candidates from k = 1 upwards; returns the calibration for ``summary.json``."""
        run = self.run
        hosts = run.desc["hosts"]
        setup = ProbeSetup(self.sdc_host, hosts[self.sdc_host]["ip"], self.turbines,
                           {wt: wire.turbine_id(hosts[wt]["cluster"], hosts[wt]["number"]) for wt in self.turbines})
        started = time.time()
        echo = None
        trials: list[dict] = []
        try:
            for sw, lines in self.flows.items():
                self._ofctl(["add-flows", sw, "-"], "\n".join(lines) + "\n")
            if self.turbines:
                ready = run.out / "calibration_echo.json"
                ready.unlink(missing_ok=True)
                echo = run.net.get(self.sdc_host).popen(
                    [sys.executable, "-m", "sdvisc.probe", "echo", "--bind", setup.sdc_ip, "--out", str(ready)],
                    stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                deadline = time.time() + 10
                while not ready.exists():
                    if echo.poll() is not None or time.time() > deadline:
                        raise RuntimeError(f"calibration: the probe echo on {self.sdc_host} did not start")
                    time.sleep(0.02)
                for wt in self.turbines:
                    sock = udp_socket_in(run.net.get(wt).pid, hosts[wt]["ip"], probe.PROBE_PORT)
                    probe.enable_rx_timestamps(sock)
                    setup.socks[wt] = sock
            self._model(setup)
            for k in CANDIDATES:
                trial = self._trial(setup, k)
                trials.append(trial)
                if trial["ok"]:
                    break
        finally:
            for sock in setup.socks.values():
                sock.close()
            if echo is not None:
                echo.terminate()
                try:
                    echo.wait(timeout=5)
                except subprocess.TimeoutExpired:
                    echo.kill()
            for sw in self.flows:
                self._ofctl(["del-flows", sw, f"{PROBE_COOKIE_TEXT}/-1"])
            left = [sw for sw in self.flows if PROBE_COOKIE_TEXT in self._ofctl(["dump-flows", sw])]
            if left:
                raise RuntimeError(f"calibration: probe rules still on {left} after removing them")
        k, met = choose(trials)
        return {"time_scale": k, "met": met, "turbines": self.turbines, "sdc": self.sdc_host,
                "limits": {"busy": BUSY_LIMIT, "one_way_p99_sim_ms": ONE_WAY_LIMIT_STEPS * self.step_s * 1e3},
                "trials": trials, "wall_s": round(time.time() - started, 2),
                "plant_model": run.scenario.plant.model}

    # ------------------------------------------------------------------ one candidate
    def _step_model(self, setup: ProbeSetup) -> tuple[float, float]:
        """One plant step with the remote turbines held at their operating point, then one SDC
        round on the plant's measurements; returns (plant s, SDC s) of compute."""
        t0 = time.perf_counter()
        model = setup.model
        model.step()
        meas = model.measurements()
        if setup.indices:
            idx = np.asarray(setup.indices)
            v = meas["v_d"][idx] + 1j * meas["v_q"][idx]
            i = meas["i_d"][idx] + 1j * meas["i_q"][idx]
            v_conv = v + complex(FILTER_R_F_PU, FILTER_X_F_PU) * i
            model.apply_remote(idx, v_conv.real, v_conv.imag, i.real, i.imag)
        t1 = time.perf_counter()
        if setup.bank is not None:
            rows = {name: np.asarray(meas[name])[idx] for name in MEAS_FIELDS}
            setup.bank.step(np.arange(len(idx)), rows)
        return t1 - t0, time.perf_counter() - t1

    def _trial(self, setup: ProbeSetup, k: float) -> dict:
        period = k * self.step_s
        steps = max(MIN_PROBE_STEPS, int(PROBE_WALL_S / period))
        plant_s = np.empty(steps)
        sdc_s = np.empty(steps)
        fwd: dict[str, list[float]] = {wt: [] for wt in setup.turbines}
        back: dict[str, list[float]] = {wt: [] for wt in setup.turbines}
        dst = (setup.sdc_ip, probe.PROBE_PORT)
        start = time.perf_counter()
        for n in range(steps):
            delay = start + n * period - time.perf_counter()
            if delay > 0:
                time.sleep(delay)
            plant_s[n], sdc_s[n] = self._step_model(setup)
            for wt, sock in setup.socks.items():
                sock.sendto(probe.encode(setup.wids[wt], n, time.time_ns()), dst)
            self._drain(setup, fwd, back)
        time.sleep(max(0.2, 20 * period))
        self._drain(setup, fwd, back)
        per_turbine = {wt: {"to_sdc_ms": delay_summary(fwd[wt]), "to_turbine_ms": delay_summary(back[wt]),
                            "lost": steps - len(back[wt])} for wt in setup.turbines}
        worst = max((max(np.percentile(fwd[wt], 99), np.percentile(back[wt], 99)) for wt in setup.turbines
                     if fwd[wt] and back[wt]), default=None)
        lost = sum(r["lost"] for r in per_turbine.values())
        plant_cost, sdc_cost = float(np.mean(plant_s)), float(np.mean(sdc_s))
        why_not = shortfalls(k, self.step_s, plant_cost, sdc_cost, None if worst is None else worst * 1e-3,
                             lost if lost > 0.01 * steps * max(1, len(setup.turbines)) else 0)
        return {"k": k, "steps": steps, "ok": not why_not, "why_not": why_not,
                "plant_step_us": {"mean": round(plant_cost * 1e6, 1), "p99": round(float(np.percentile(plant_s, 99)) * 1e6, 1)},
                "plant_busy": round(plant_cost / period, 3),
                "sdc_round_us": {"mean": round(sdc_cost * 1e6, 1), "p99": round(float(np.percentile(sdc_s, 99)) * 1e6, 1)},
                "sdc_busy": round(sdc_cost / period, 3),
                "one_way_p99_sim_ms": None if worst is None else round(worst / k, 4),
                "per_turbine_wall": per_turbine}

    @staticmethod
    def _drain(setup: ProbeSetup, fwd: dict, back: dict) -> None:
        for wt, sock in setup.socks.items():
            while (got := probe.recv_stamped(sock)) is not None:
                data, _addr, t_rx = got
                decoded = probe.decode(data)
                if decoded is None or decoded[0] != setup.wids[wt] or decoded[3] == 0:
                    continue
                _, _, t_send, t_echo = decoded
                fwd[wt].append((t_echo - t_send) * 1e-6)
                back[wt].append((t_rx - t_echo) * 1e-6)


def calibration_line(calibration: dict) -> str:
    """One line for the terminal: what each candidate measured and what was chosen."""
    parts = []
    for t in calibration["trials"]:
        p99 = t["one_way_p99_sim_ms"]
        parts.append(f"k={t['k']:g}: plant {t['plant_busy']:.0%}, SDC {t['sdc_busy']:.0%}, one-way p99 "
                     + (f"{p99:.3f} ms" if p99 is not None else "-") + (" ok" if t["ok"] else ""))
    verdict = "chosen" if calibration["met"] else "the largest tried; limits NOT met"
    return f"sdvisc: time scale {calibration['time_scale']:g} ({verdict}): " + "; ".join(parts)
