"""Play a scenario on real Mininet hosts, Open vSwitch bridges and the os-ken SDN application.

:func:`run_scenario` builds the network, starts the SDN app, the SDC(s), the OWFCC and the plant,
plays the timeline against the wall clock (progress bar and status line on the terminal), writes
``summary.json``, ``events.jsonl`` and ``timeseries.csv`` to the output directory, and tears
everything down on every exit path (normal end, exception, Ctrl-C, SIGTERM).
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path
from types import SimpleNamespace

from host_tools import cleanup, cpu_split, ovs_revalidation
from host_tools.child_signals import bound_node_stops, give_children_default_signals, shield_signals
from scenarios import configs, switch_links, switch_ports
from scenarios.calibration_cache import after_run, choose_time_scale
from scenarios.cluster_run import ClusterRun, set_link_by_shell
from scenarios.external import ExternalDevices
from scenarios.feedback import progress_line
from scenarios.impairments import Impairments
from scenarios.live import Session, check_open_ended
from scenarios.netprep import local_vsctl, mark_switches, prepare_hosts, reconnect_controllers
from scenarios.processes import Processes, RunError
from scenarios.run_state import RunState
from scenarios.schema import Scenario
from scenarios.summary import build_summary
from scenarios.timeline import Timeline
from sdvisc.clock import Clock
from sdvisc.config import CONTROLLER_VIP, CONTROLLER_VMAC, write_config
from topologies.base import INTAKE_HOST, CheckedController, TestbedSwitch, default_datapath, describe

SWITCH_CONNECT_TIMEOUT_S = 30.0


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _raise_interrupt(signum, frame):
    raise KeyboardInterrupt(f"signal {signum}")


class Run(RunState):
    """One scenario run; use :func:`run_scenario`."""

    def __init__(self, scenario: Scenario, out_dir: Path, *, quiet: bool = False) -> None:
        self.scenario = scenario
        self.out = out_dir
        self.quiet = quiet
        self.net = None
        self.timeline_events: list[dict] = []
        self.t0: float | None = None  # the run clock's reading at t = 0 (simulated seconds)
        self.auto_time_scale = scenario.time_scale == "auto"
        self.calibrate_from: float | None = None  # auto: the k to try first (scenarios.calibrate.search)
        self.recalibrate = False  # auto: measure even when the calibration cache has this shape
        self.calibration: dict | None = None  # what `time_scale: auto` measured (scenarios.calibrate)
        self.switch_ports: dict = {}  # scenarios.switch_ports.use: requested, used, refused
        self.cpu_split: dict = {"applied": False, "why": "off"}  # host_tools.cpu_split.apply
        self.switch_revalidation: dict = {"applied": False, "why": "off"}  # host_tools.ovs_revalidation.apply
        self.setup_wall_s: dict[str, float] = {}  # wall seconds per set-up phase (build, start, hosts, calibration)
        self.teardown_wall_s: dict[str, float] = {}  # … and per teardown phase (each process's stop, mininet)
        self.set_time_scale(1.0 if self.auto_time_scale else scenario.time_scale)
        self.wall_started: float | None = None
        self.wall_ended: float | None = None
        self.cpu_at_start: dict[str, float] = {}
        self.cpu_at_controllers_stop: dict[str, float] = {}
        self.cpu_used: dict[str, float] = {}
        self.desc: dict | None = None
        self.python = sys.executable
        self.finished = threading.Event()
        self.datapath = default_datapath()
        self.links_down: set[tuple[str, str]] = set()
        self.processes = Processes(out_dir, self.record)
        self.session = None  # an interactive session (scenarios.live.Session): runs until the user ends it
        self.timeline = Timeline(self)
        self.impairments = Impairments(scenario, out_dir)  # link delay/jitter/loss/bandwidth (netem or elements)
        self.external = ExternalDevices(scenario)  # an external peer, hardware switches (scenarios/external.py)
        self.cluster = ClusterRun(scenario.cluster) if scenario.cluster else None  # across servers

    # what summary.json reports about the processes
    procs = property(lambda self: self.processes.procs)
    killed = property(lambda self: self.processes.killed)
    restarts = property(lambda self: self.processes.restarts)
    exited_early = property(lambda self: self.processes.exited_early)
    no_controller = property(lambda self: self.processes.no_controller)

    def set_time_scale(self, k: float) -> None:
        """The run's one clock, shared by every process (set before any of them starts)."""
        self.clock = Clock(k, time.time())
        self.clock_settings = {"time_scale": self.clock.time_scale, "clock_epoch": self.clock.epoch}

    def record(self, event: dict) -> None:
        """Add an event of the runner's own (timeline actions, restarts, CLI actions) to events.jsonl."""
        self.timeline_events.append(event)

    def command(self, process: str, obj: dict) -> bool:
        """Send one JSON-line command to a process (``owfcc.owfcc``, ``plant``)."""
        return self.processes.send(process, obj)

    def controllers_running(self) -> bool:
        return self.processes.controllers_running()

    # ------------------------------------------------------------------ set-up
    def _say(self, text: str) -> None:
        if not self.quiet:
            print(text, flush=True)

    def build(self) -> None:
        from mininet.link import Link, OVSLink
        from mininet.log import setLogLevel
        from mininet.net import Mininet

        setLogLevel("warning")
        sc = self.scenario
        if sc.cpu_split:  # before any host shell or service starts: they inherit the run's CPUs
            self.cpu_split = cpu_split.apply()
            if not self.cpu_split["applied"]:
                self._say(f"sdvisc: cpu_split not applied: {self.cpu_split['why']}")
        if sc.switch_revalidation_ms:  # before the calibration: it measures the run's switches
            self.switch_revalidation = ovs_revalidation.apply(sc.switch_revalidation_ms)
        topo = self.impairments.build_topology(sc.topology.topo_class(), sc.topology.params())
        if sc.sdn.uses_intake_socket(any(s["openflow"] for s in describe(topo)["switches"].values())):
            topo.add_intake(CONTROLLER_VIP, CONTROLLER_VMAC)
        self.desc = describe(topo)
        if self.external.active:  # out of Mininet's hands; the app still sees the whole network
            self.desc = self.external.detach(topo, self.desc)
        ports = [_free_port(), _free_port()]
        self._say(f"sdvisc: building topology {sc.topology.name} {sc.topology.params()} "
                  f"({len(self.desc['switches'])} switches, {len(self.desc['hosts'])} hosts, datapath {self.datapath})")
        phase = self._phase_timer()
        if self.cluster is not None:  # the switches and SDCs on servers, tunnels between places
            self.cluster.start_servers()
            phase("servers")
            self.net = self.cluster.build_net(topo, self.desc, controller=None, build=False)
            self._say(f"sdvisc: across servers {', '.join(self.cluster.servers)} (head {self.cluster.head_ip})")
        else:
            self.net = Mininet(topo=topo, switch=TestbedSwitch, controller=None, build=False, autoSetMacs=False,
                               waitConnected=False, link=OVSLink if sc.switch_links == "patch" else Link)
        for name, port in zip(("c0", "c1"), ports[:2 if sc.sdn.redundancy else 1]):
            self.net.addController(name, controller=CheckedController, ip=self.controller_ip, port=port)
        self.net.build()
        if self.external.active:
            self.external.make(ports[0])
            self.external.attach(self.net)
        phase("mininet_build")
        self.net.start()
        phase("switches_start")
        for vsctl, group in self.switch_groups(self.net.switches):
            mark_switches(group, vsctl)
        self.switch_ports = switch_ports.use(switch_ports.port_names(self.net.switches), sc.switch_ports)
        if self.switch_ports.get("refused"):
            self._say(f"sdvisc: {sc.switch_ports} switch ports refused ({self.switch_ports['refused']}): using system ports")
        phase("switch_ports")
        prepare_hosts(self.net.hosts, CONTROLLER_VIP, CONTROLLER_VMAC)
        self.external.prepare_hosts(self.net, self.desc)
        phase("hosts_prepare")
        self.impairments.start(self)
        if self.auto_time_scale:  # measured before the SDN app starts (its config carries the clock)
            self.calibration = choose_time_scale(self)  # the cache's k, else probed at k = 1, 2, 4, …
            self.set_time_scale(self.calibration["time_scale"])
            self.impairments.set_clock(self.clock_settings)
            self._say(self.calibration["line"])
            phase("calibration")
        # once the hosts exist (the intake socket opens in ctl's); switches reconnect now, not after a back-off
        self._start_sdn_apps(ports)
        for vsctl, group in self.switch_groups([*self.net.switches, *(SimpleNamespace(name=n)
                                                                     for n in self.external.bridge_names())]):
            reconnect_controllers(group, vsctl)
        self._wait_switches()
        phase("switches_connect")
        if self.cluster is not None:
            self.processes.extra_cpu = self.cluster.cpu_seconds  # each server's ovs-vswitchd

    @property
    def controller_ip(self) -> str:
        """Where the SDN app listens and the switches connect: the head's LAN address across servers."""
        return self.cluster.head_ip if self.cluster is not None else "127.0.0.1"

    def switch_groups(self, switches) -> list:
        """(ovs-vsctl caller, switches) per machine that holds some of ``switches``."""
        if self.cluster is not None:
            return self.cluster.switch_groups(switches)
        return [(local_vsctl, list(switches))] if switches else []

    def ovs_tool(self, tool: str, args: list[str], switch: str, stdin: str | None = None) -> subprocess.CompletedProcess:
        """``tool ARGS`` (ovs-ofctl, ...) on the machine that holds ``switch``."""
        if self.cluster is not None:
            return self.cluster.ovs_tool(tool, args, switch, stdin)
        return subprocess.run([tool, *args], input=stdin, capture_output=True, text=True, timeout=60)

    def _phase_timer(self, into: dict[str, float] | None = None):
        """A function that records the wall seconds since its previous call under a phase's name
        (summary.json: time.setup_wall_s, time.teardown_wall_s)."""
        into = self.setup_wall_s if into is None else into
        last = [time.perf_counter()]

        def phase(name: str) -> None:
            now = time.perf_counter()
            into[name] = round(now - last[0], 3)
            last[0] = now
        return phase

    def _start_sdn_apps(self, ports: list[int]) -> None:
        sc = self.scenario
        intake = self.net.get(INTAKE_HOST).pid if "intake_ports" in self.desc else None
        cfg_path = write_config(configs.app_config(sc, self.desc, str(self.out), self.clock_settings, intake_pid=intake),
                                self.out / "sdn_config.json")
        app = [self.python, "-m", "sdn_app", "--config", str(cfg_path), "--listen-host", self.controller_ip]
        a, b = (_free_port(), _free_port()) if sc.sdn.redundancy else (0, 0)  # the pair's peer heartbeat
        apps = ([("controller", ports[0], ["--role", "master", "--instance", "1", "--peer", f"{a}:{b}"]),
                 ("controller2", ports[1], ["--role", "slave", "--instance", "2", "--peer", f"{b}:{a}"])]
                if sc.sdn.redundancy else [("controller", ports[0], [])])
        for name, port, role in apps:
            self.processes.start(name, app + ["--ofp-port", str(port), *role])
        for name, port, _ in apps:
            self.processes.wait_listening(name, port, "SDN app", SWITCH_CONNECT_TIMEOUT_S, host=self.controller_ip)

    def _wait_switches(self) -> None:
        want = {s["dpid"] for s in self.desc["switches"].values() if s["openflow"]}
        deadline = time.time() + SWITCH_CONNECT_TIMEOUT_S
        while time.time() < deadline:
            if self.procs["controller"].poll() is not None:
                raise RunError(f"SDN app exited with {self.procs['controller'].returncode}; see {self.out}/controller.log")
            states = [self._read_state(n) for n in self._sdn_state_files()]
            if states and all(st and want <= set(st["tables"].get("connected", [])) for st in states):
                return
            time.sleep(0.1)
        raise RunError(f"switches did not connect to the SDN app within {SWITCH_CONNECT_TIMEOUT_S:.0f} s")

    def start_services(self) -> None:
        sc = self.scenario
        hosts = self.desc["hosts"]
        out = str(self.out)
        for host, sdc_id, role in configs.sdcs(sc):
            cfg = write_config(configs.sdc_config(sc, self.desc, out, sdc_id, role, self.clock_settings), self.out / f"{host}_config.json")
            self.processes.start(f"{host}.sdc", [self.python, "-m", "sdc_unit.service", "--config", str(cfg)],
                        host=self.net.get(host))
        cfg = write_config(configs.owfcc_config(sc, out, self.clock_settings), self.out / "owfcc_config.json")
        self.processes.start("owfcc.owfcc", [self.python, "-m", "owfcc.service", "--config", str(cfg)],
                    host=self.net.get("owfcc"), stdin=subprocess.PIPE)
        if sc.capture.pcap:
            for h in sc.capture.hosts:
                node = self.net.get(h)
                self.processes.start(f"{h}.tcpdump", ["tcpdump", "-i", node.defaultIntf().name, "-B", "16384", "--immediate-mode", "-w",
                                             str(self.out / f"sdvisc-capture-{h}.pcap"), "udp"], host=node)
        for host, sdc_id, _ in configs.sdcs(sc):  # the plant starts only when every SDC is ready
            self.processes.wait_ready(f"{host}.sdc", f"sdc{sdc_id}_ready.json", f"SDC on {host}")
        time.sleep(0.3)  # let the other services bind their sockets
        if self.external.peer is not None:  # the peer is the plant: the emulated card, or nothing of ours
            self.t0 = self.external.start_peer(self, hosts["sdc1"]["ip"])
        else:
            pids = {n: self.net.get(n).pid for n, h in hosts.items() if h["role"] == "turbine"}
            cfg = write_config(configs.plant_config(sc, self.desc, out, pids, self.clock_settings,
                                                    open_ended=self.session is not None), self.out / "plant_config.json")
            self.processes.start("plant", [self.python, "-m", "plant.service", "--config", str(cfg)], stdin=subprocess.PIPE)
            # the plant sets t = 0 (wall time) once its model is built and warmed up
            self.t0 = float(self.processes.wait_ready("plant", "plant_ready.json", "the plant")["t0_wall"])
        if self.cpu_split["applied"]:  # where each process may run (summary.json cpu_split.seen)
            self.cpu_split["seen"] = cpu_split.seen({n: p.pid for n, p in self.procs.items()})
        self.wall_started = self.clock.to_wall(self.t0)

    def set_link(self, a: str, b: str, up: bool) -> float:
        """Set the link a–b up or down (:func:`scenarios.switch_links.set_link`: both ends, the
        run clock's reading before the first); a link to an external device: its root-namespace ends."""
        ends = self.external.link_ends(a, b) or self.impairments.link_ends(self.net, a, b)
        if not ends:
            raise RunError(f"no link {a}-{b}")
        (self.links_down.discard if up else self.links_down.add)(tuple(sorted((a, b))))
        try:
            if self.cluster is not None:  # ends on servers: through their nodes' shells
                return self.clock.from_wall(set_link_by_shell(ends, up))
            return self.clock.from_wall(switch_links.set_link(ends, up, self.net.switches))
        except OSError as exc:
            raise RunError(f"cannot set the link {a}-{b} {'up' if up else 'down'}: {exc}") from exc

    def play(self) -> None:
        """Play the timeline and show progress until the plant has run the scenario's duration."""
        pending = sorted(self.scenario.timeline, key=lambda e: e.t)
        tty = sys.stdout.isatty() and not self.quiet
        last_line = 0.0
        plant = self.procs.get("plant")  # None: a real external peer, nothing of ours keeps the time
        end = self.t0 + self.scenario.duration_s if self.session is None else float("inf")  # a session: until exit
        while plant.poll() is None if plant is not None else self.clock.now() < end:
            now = self.clock.now()
            if not self.cpu_at_start and now >= self.t0:
                self.cpu_at_start = self.processes.cpu_seconds()  # from t = 0: start-up compiles left out
            if now >= end or (self.session is not None and self.session.ending(now - self.t0)):
                if not self.processes.controllers_stopping:  # their CPU up to here: they are gone at the end
                    self.cpu_at_controllers_stop = self.processes.cpu_seconds()
                self.processes.stop_controllers()  # the scenario is over: no decisions on the plant's last packets
            self.processes.supervise(round(now - self.t0, 6))
            while pending and now >= self.t0 + pending[0].t:
                event = pending.pop(0)
                self.timeline.dispatch(event, now - self.t0)
            if self.session is None and now - last_line >= (0.2 if tty else 1.0):  # a session: `status`
                last_line = now
                self._progress(tty)
            wait = self.clock.wall_s(self.t0 + pending[0].t - self.clock.now()) if pending else 0.02
            time.sleep(min(0.02, max(0.0, wait)))
        if plant is not None and plant.returncode != 0:
            raise RunError(f"plant exited with {plant.returncode}; see {self.out}/plant.log")
        self.wall_ended = time.time()
        cpu_at_end = {**self.cpu_at_controllers_stop, **self.processes.cpu_seconds()}
        self.cpu_used = {n: round(c - self.cpu_at_start[n], 4) for n, c in cpu_at_end.items() if n in self.cpu_at_start}
        if self.session is None:
            self._progress(tty, final=True)
        self.finished.set()

    def _progress(self, tty: bool, final: bool = False) -> None:
        if self.quiet:
            return
        line = progress_line(self.progress_status(), self.scenario.duration_s)
        if tty:
            print("\r" + line.ljust(110), end="\n" if final else "", flush=True)
        else:
            print(line, flush=True)

    # ------------------------------------------------------------------ teardown
    def teardown(self) -> None:
        phase = self._phase_timer(self.teardown_wall_s)
        try:
            self.impairments.finish()
            self.processes.stop_all(self.teardown_wall_s)
        finally:
            phase("processes")
            if self.net is not None:
                try:
                    if self.cluster is not None:
                        self.cluster.prune_lost(self.net)
                    bound_node_stops(self.net)  # no node's shell can make Mininet's stop wait for ever
                    self.net.stop()
                except Exception as exc:  # noqa: BLE001 - teardown must go on
                    print(f"sdvisc: mininet stop failed ({exc}); cleaning up", file=sys.stderr)
            phase("mininet_stop")
            self.external.remove()
            if self.cluster is not None:
                self.cluster.remove()
            cleanup.clean()  # also undoes the CPU split and the switches' revalidation period
            phase("cleanup")


def run_scenario(scenario: Scenario, out_dir: str | Path, *, cli: bool = False, quiet: bool = False,
                 source: str | None = None, cli_duration_s: float | None = None, web_port: int | None = None,
                 calibrate_from: float | None = None, recalibrate: bool = False) -> dict:
    """Run ``scenario``; returns the summary (also written to ``out_dir/summary.json``). With ``cli``, an
    interactive session (:mod:`scenarios.live`) that ends on ``exit`` or at ``cli_duration_s``;
    ``web_port``: its live view (:mod:`scenarios.web`)."""
    check_open_ended(scenario.duration_s, cli)
    give_children_default_signals()  # under nohup every child would inherit SIGHUP ignored (issue 42)
    if os.geteuid() != 0:
        raise RunError("sdvisc run needs root (Mininet creates namespaces, veths and bridges)")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    for stale in out.glob("*"):
        if stale.is_file():
            stale.unlink()
    left = cleanup.leftovers()
    if any(left.values()):
        print(f"sdvisc: removing leftovers of an earlier run: {left}", file=sys.stderr)
        cleanup.clean()
    previous = {s: signal.signal(s, _raise_interrupt) for s in (signal.SIGTERM, signal.SIGHUP)}
    unmark = cleanup.mark_children()  # every process the run starts (Mininet's shells too) is the clean-up's
    run = Run(scenario, out, quiet=quiet)
    run.calibrate_from, run.recalibrate = calibrate_from, recalibrate
    if cli:
        run.session = Session(run, cli_duration_s=cli_duration_s, web_port=web_port)
    completed = False
    try:
        run.build()
        run.start_services()
        if cli:
            completed = run.session.interact()
        else:
            run.play()
            completed = True
    finally:
        shielded = shield_signals()  # a second Ctrl-C or SIGTERM must not cut the (bounded) teardown short
        try:
            run.teardown()
        finally:
            for s, handler in {**shielded, **previous}.items():
                signal.signal(s, handler)
            unmark()
            if run.session is not None:
                run.session.settle_duration()  # summary.json covers the whole session
            summary = build_summary(run, completed=completed, source=source)
            if run.calibration is not None and completed:  # the run checks the k it was given; the cache learns
                summary["time"]["calibration"].update(after_run(run.calibration, summary.get("advice")))
            (out / "summary.json").write_text(json.dumps(summary, indent=1))
    return summary
