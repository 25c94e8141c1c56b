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

from mininet.node import RemoteController

from scenarios import configs
from scenarios.schema import Scenario
from scenarios.summary import build_summary
from sdvisc import cleanup, wire
from sdvisc.config import CONTROLLER_VIP, CONTROLLER_VMAC, write_config
from sdvisc.netns import set_link_up
from topologies import topos
from topologies.base import TestbedSwitch, default_datapath, describe

MAX_RESTARTS = 3  # per service and run
RESTARTABLE = (".sdc", "owfcc.owfcc", "controller", "controller2")  # the plant is the run's clock: never
SWITCH_CONNECT_TIMEOUT_S = 30.0
READY_TIMEOUT_S = 120.0


class RunError(RuntimeError):
    """The run could not be set up or did not complete."""


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class CheckedController(RemoteController):
    """Mininet's RemoteController without its telnet probe: the runner checks the port itself, and
    the probe can choke on the OpenFlow HELLO bytes os-ken sends back (UnicodeDecodeError)."""

    def checkListening(self):
        pass


def _raise_interrupt(signum, frame):
    raise KeyboardInterrupt(f"signal {signum}")


class Run:
    """One scenario run; use :func:`run_scenario`."""

    def __init__(self, scenario: Scenario, out_dir: Path, *, quiet: bool = False) -> None:
        self.scenario = scenario
        self.out = out_dir
        self.quiet = quiet
        self.net = None
        self.procs: dict[str, subprocess.Popen] = {}
        self.timeline_events: list[dict] = []
        self.t0: float | None = None
        self.desc: dict | None = None
        self.python = sys.executable
        self._stdin_lock = threading.Lock()
        self.finished = threading.Event()
        self.datapath = default_datapath()
        self.exited_early: dict[str, int] = {}
        self.links_down: set[tuple[str, str]] = set()
        self.killed: set[str] = set()
        self.specs: dict[str, tuple] = {}  # how each service was started (to restart it)
        self.restarts: dict[str, list[dict]] = {}
        self.no_controller: list[list[float | None]] = []  # [t_from, t_to or None]: no SDN app running

    # ------------------------------------------------------------------ set-up
    def _say(self, text: str) -> None:
        if not self.quiet:
            print(text, flush=True)

    def _write_json(self, name: str, data: dict) -> Path:
        path = self.out / name
        path.write_text(json.dumps(data, indent=1))
        return path

    def _popen(self, name: str, args: list[str], host=None, stdin=None, mode: str = "w") -> subprocess.Popen:
        self.specs[name] = (args, host, stdin)
        log = open(self.out / f"{name}.log", mode)  # noqa: SIM115 - owned by the process
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        if host is None:
            proc = subprocess.Popen(args, stdin=stdin, stdout=log, stderr=subprocess.STDOUT, env=env,
                                    start_new_session=True)
        else:
            proc = host.popen(args, stdin=stdin, stdout=log, stderr=subprocess.STDOUT, env=env)
        self.procs[name] = proc
        return proc

    def build(self) -> None:
        from mininet.log import setLogLevel
        from mininet.net import Mininet

        setLogLevel("warning")
        sc = self.scenario
        topo = topos[sc.topology.name](**sc.topology.params())
        self.desc = describe(topo)
        port = _free_port()
        cfg_path = write_config(configs.app_config(sc, self.desc, str(self.out)), self.out / "sdn_config.json")
        app = [self.python, "-m", "sdn_app", "--config", str(cfg_path)]
        if sc.sdn.redundancy:
            port2, peer_a, peer_b = _free_port(), _free_port(), _free_port()
            self._popen("controller", app + ["--ofp-port", str(port), "--role", "master", "--instance", "1",
                                             "--peer", f"{peer_a}:{peer_b}"])
            self._popen("controller2", app + ["--ofp-port", str(port2), "--role", "slave", "--instance", "2",
                                              "--peer", f"{peer_b}:{peer_a}"])
            self._wait_listening(port, "controller")
            self._wait_listening(port2, "controller2")
        else:
            self._popen("controller", app + ["--ofp-port", str(port)])
            self._wait_listening(port, "controller")
        self._say(f"sdvisc: building topology {sc.topology.name} {sc.topology.params()} "
                  f"({len(self.desc['switches'])} switches, {len(self.desc['hosts'])} hosts, datapath {self.datapath})")
        self.net = Mininet(topo=topo, switch=TestbedSwitch, controller=None, build=False, autoSetMacs=False,
                           waitConnected=False)
        self.net.addController("c0", controller=CheckedController, ip="127.0.0.1", port=port)
        if sc.sdn.redundancy:
            self.net.addController("c1", controller=CheckedController, ip="127.0.0.1", port=port2)
        self.net.build()
        self.net.start()
        for sw in self.net.switches:
            sw.cmd(f"ovs-vsctl br-set-external-id {sw.name} sdvisc 1")
        for host in self.net.hosts:
            for intf in host.intfList():
                host.cmd(f"ethtool -K {intf.name} tx off")
        self.net.staticArp()
        for host in self.net.hosts:
            host.cmd(f"arp -s {CONTROLLER_VIP} {CONTROLLER_VMAC}")
        self._wait_switches()

    def _wait_listening(self, port: int, name: str) -> None:
        deadline = time.time() + SWITCH_CONNECT_TIMEOUT_S
        while time.time() < deadline:
            if self.procs[name].poll() is not None:
                raise RunError(f"SDN app exited with {self.procs[name].returncode}; see {self.out}/{name}.log")
            with socket.socket() as s:
                if s.connect_ex(("127.0.0.1", port)) == 0:
                    return
            time.sleep(0.1)
        raise RunError(f"SDN app did not listen on port {port} within {SWITCH_CONNECT_TIMEOUT_S:.0f} s")

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

    def _sdn_state_files(self) -> list[str]:
        return ["sdn_state.json"] + (["sdn2_state.json"] if self.scenario.sdn.redundancy else [])

    def _read_state(self, name: str) -> dict | None:
        try:
            return json.loads((self.out / name).read_text())
        except (OSError, json.JSONDecodeError):
            return None

    def sdn_state(self) -> dict | None:
        """The live view of the SDN app in charge (the master, with a redundant pair)."""
        states = [s for s in (self._read_state(n) for n in self._sdn_state_files()) if s]
        if not states:
            return None
        masters = [s for s in states if s.get("role") in ("master", "equal")]
        return max(masters or states, key=lambda s: (s.get("generation", 0), s.get("t_wall", 0)))

    def plant_status(self) -> dict | None:
        try:
            return json.loads((self.out / "plant_status.json").read_text())
        except (OSError, json.JSONDecodeError):
            return None

    def start_services(self) -> None:
        sc = self.scenario
        hosts = self.desc["hosts"]
        out = str(self.out)
        for host, sdc_id, role in configs.sdcs(sc):
            cfg = write_config(configs.sdc_config(sc, self.desc, out, sdc_id, role), self.out / f"{host}_config.json")
            self._popen(f"{host}.sdc", [self.python, "-m", "sdc_unit.service", "--config", str(cfg)],
                        host=self.net.get(host))
        cfg = write_config(configs.owfcc_config(sc, out), self.out / "owfcc_config.json")
        self._popen("owfcc.owfcc", [self.python, "-m", "sdvisc.owfcc", "--config", str(cfg)],
                    host=self.net.get("owfcc"), stdin=subprocess.PIPE)
        if sc.capture.pcap:
            for h in sc.capture.hosts:
                node = self.net.get(h)
                self._popen(f"{h}.tcpdump", ["tcpdump", "-i", node.defaultIntf().name, "-B", "16384", "--immediate-mode", "-w",
                                             str(self.out / f"sdvisc-capture-{h}.pcap"), "udp"], host=node)
        for host, sdc_id, _ in configs.sdcs(sc):  # the plant starts only when every SDC is ready
            self._wait_ready(f"{host}.sdc", f"sdc{sdc_id}_ready.json", f"SDC on {host}")
        time.sleep(0.3)  # let the other services bind their sockets
        pids = {n: self.net.get(n).pid for n, h in hosts.items() if h["role"] == "turbine"}
        cfg = write_config(configs.plant_config(sc, self.desc, out, pids), self.out / "plant_config.json")
        self._popen("plant", [self.python, "-m", "plant.service", "--config", str(cfg)], stdin=subprocess.PIPE)
        # the plant sets t = 0 (wall time) once its model is built and warmed up
        self.t0 = float(self._wait_ready("plant", "plant_ready.json", "the plant")["t0_wall"])

    def _wait_ready(self, proc_name: str, ready_file: str, what: str, timeout_s: float = READY_TIMEOUT_S) -> dict:
        """Wait for a service's ``ready_file`` (JSON, written atomically once it has warmed up: its
        first run on a machine compiles numba code, some seconds); returns its content."""
        ready, end = self.out / ready_file, time.time() + timeout_s
        while True:
            try:
                return json.loads(ready.read_text())
            except (OSError, ValueError):
                pass
            log = self.out / f"{proc_name}.log"
            if self.procs[proc_name].poll() is not None:
                raise RunError(f"{what} exited during start-up; see {log}")
            if time.time() > end:
                raise RunError(f"{what} not ready after {timeout_s:.0f} s; see {log}")
            time.sleep(0.02)

    # ------------------------------------------------------------------ timeline
    def _to_stdin(self, name: str, obj: dict) -> None:
        proc = self.procs.get(name)
        if proc is None or proc.poll() is not None or proc.stdin is None:
            return
        with self._stdin_lock:
            try:
                proc.stdin.write((json.dumps(obj) + "\n").encode())
                proc.stdin.flush()
            except (BrokenPipeError, OSError):
                pass

    def dispatch(self, event, t: float) -> None:
        """Carry out one timeline event now."""
        kind = event.do
        record = {"t": round(t, 6), "source": "timeline", "type": kind,
                  **event.model_dump(exclude={"t", "do"})}
        self.timeline_events.append(record)
        if kind in ("visc_on", "visc_off", "set_params"):
            self._to_stdin("owfcc.owfcc", {"cmd": kind, "wt": event.wt, "params": getattr(event, "params", {})})
        elif kind in ("link_down", "link_up"):
            record["t_effective"] = round(self.set_link(event.a, event.b, kind == "link_up") - self.t0, 6)
        elif kind == "path_link_down":
            link = self.current_path_link(event.wt, event.hop)
            if link is None:
                record["type"] = "path_link_down_skipped"
                record["reason"] = f"{event.wt} has no installed path with switch-to-switch links"
            else:
                record.update(type="link_down", a=link[0], b=link[1], requested="path_link_down")
                record["t_effective"] = round(self.set_link(link[0], link[1], False) - self.t0, 6)
        elif kind == "restore_links":
            down = sorted(self.links_down)
            for a, b in down:
                self.set_link(a, b, True)
            record["links"] = down
        elif kind == "kill":
            name = event.process if event.process.startswith("controller") else f"{event.host}.{event.process}"
            proc = self.procs.get(name)
            if proc is not None and proc.poll() is None:
                if not event.crash:
                    self.killed.add(name)  # planned: never restarted (a crash is, by supervise)
                proc.kill()
        elif kind in ("fuzz", "spoof_ak"):
            record["out"] = self.start_fuzzer(event, len([e for e in self.timeline_events if e["type"] == kind]))
        elif kind == "set":
            self._to_stdin("plant", {"type": "set", "param": event.param, "value": event.value})
        elif kind == "load_step":
            self._to_stdin("plant", {"type": "load_step", "mw": event.mw})
        elif kind == "scr":
            self._to_stdin("plant", {"type": "scr", "value": event.value})
        elif kind == "fault":
            self._to_stdin("plant", {"type": "fault", "on": True})
            timer = threading.Timer(max(0.0, self.t0 + t + event.duration_s - time.time()),
                                    self._to_stdin, args=("plant", {"type": "fault", "on": False}))
            timer.daemon = True
            timer.start()

    def start_fuzzer(self, event, number: int) -> str:
        """Start :mod:`sdvisc.fuzz` in ``event.host``'s namespace: hostile datagrams at
        ``event.targets`` (``fuzz``) or AKs for another turbine (``spoof_ak``)."""
        hosts = self.desc["hosts"]
        me = hosts[event.host]
        name = f"{event.do}{number}_{event.host}"
        cfg = {"count": event.count, "duration_s": event.duration_s, "out": str(self.out / f"{name}.json")}
        if event.do == "spoof_ak":
            victim = hosts[event.victim]
            who = victim if event.impersonate else me
            cfg.update(mode="spoof_ak", victim_wid=wire.turbine_id(victim["cluster"], victim["number"]), ak=event.ak,
                       src_ip=who["ip"], src_mac=who["mac"], dst_ip=CONTROLLER_VIP, dst_mac=CONTROLLER_VMAC,
                       iface=self.net.get(event.host).defaultIntf().name, seq0=100_000)
        else:
            def port(target: str) -> int:
                if hosts[target]["role"] == "turbine":
                    return wire.PORT_TURBINE
                return wire.PORT_OWFCC if target == "owfcc" else wire.PORT_SDC

            cfg.update(targets=[[CONTROLLER_VIP, wire.PORT_CONTROLLER] if t == "controller" else [hosts[t]["ip"], port(t)]
                                for t in event.targets], seed=event.seed, step_s=self.scenario.step_s,
                       wid=wire.turbine_id(me["cluster"], me["number"]) if me["role"] == "turbine" else 101)
        path = self._write_json(f"{name}_config.json", cfg)
        self._popen(f"{name}.fuzz", [self.python, "-m", "sdvisc.fuzz", "--config", str(path)],
                    host=self.net.get(event.host))
        return f"{name}.json"

    def current_path_link(self, wt: str, hop: int) -> tuple[str, str] | None:
        """The ``hop``-th switch-to-switch link of ``wt``'s installed path (SDC side first)."""
        state = self.sdn_state() or {}
        path = state.get("tables", {}).get("paths", {}).get(wt, {}).get("path")
        if not path:
            return None
        switches = self.desc["switches"]
        inner = [(a, b) for a, b in zip(path, path[1:]) if a in switches and b in switches]
        return inner[hop % len(inner)] if inner else None

    def set_link(self, a: str, b: str, up: bool) -> float:
        """Set the link a–b up or down; returns the wall time just before its first end was changed.

        The time is taken before the command (not after it returns, which is 1–3 ms later), so a
        recovery time measured from it can only be over-, never under-estimated.

        Each end is set with one ioctl in its namespace (switch ends: the root namespace); a veth
        whose peer is down has no carrier, so the first end takes the link down at once."""
        links = self.net.linksBetween(self.net.get(a), self.net.get(b))
        if not links:
            raise RunError(f"no link {a}-{b}")
        state = "up" if up else "down"
        if up:
            self.links_down.discard(tuple(sorted((a, b))))
        else:
            self.links_down.add(tuple(sorted((a, b))))
        t_first = None
        for intf in (links[0].intf1, links[0].intf2):
            pid = None if intf.node in self.net.switches else intf.node.pid  # switch ends: root namespace
            try:
                t = set_link_up(intf.name, up, pid)
            except OSError as exc:
                raise RunError(f"cannot set {intf.name} {state}: {exc}") from exc
            t_first = t_first or t
        return t_first

    def play(self) -> None:
        """Play the timeline and show progress until the plant has run the scenario's duration."""
        pending = sorted(self.scenario.timeline, key=lambda e: e.t)
        tty = sys.stdout.isatty() and not self.quiet
        last_line = 0.0
        plant = self.procs["plant"]
        end = self.t0 + self.scenario.duration_s
        while plant.poll() is None:
            now = time.time()
            if now >= end:
                self._stop_controller()  # the scenario is over: no decisions on the plant's last packets
            self.supervise(now)
            while pending and now >= self.t0 + pending[0].t:
                event = pending.pop(0)
                self.dispatch(event, now - self.t0)
            if now - last_line >= (0.2 if tty else 1.0):
                last_line = now
                self._progress(tty)
            wait = min(0.02, max(0.0, (self.t0 + pending[0].t - time.time()) if pending else 0.02))
            time.sleep(wait)
        if plant.returncode != 0:
            raise RunError(f"plant exited with {plant.returncode}; see {self.out}/plant.log")
        self._progress(tty, final=True)
        self.finished.set()

    def supervise(self, now: float) -> None:
        """Restart a service that died without being told to (a crash: logged as an event, counted
        in summary.json; its peers see the gap), at most MAX_RESTARTS times; and keep track of
        when no SDN application at all is running (recoveries then say ``no_controller``)."""
        if getattr(self, "_controller_stopping", False):
            return
        for name, proc in list(self.procs.items()):
            code = proc.poll()
            if code is None or name in self.killed or not name.endswith(RESTARTABLE):
                continue
            done = self.restarts.setdefault(name, [])
            if len(done) >= MAX_RESTARTS:
                continue
            args, host, stdin = self.specs[name]
            t = round(now - self.t0, 6) if self.t0 is not None else None
            try:
                self._popen(name, args, host=host, stdin=stdin, mode="a")
            except OSError as exc:
                done.append({"t": t, "exit_code": code, "error": str(exc)})
                continue
            done.append({"t": t, "exit_code": code})
            self.timeline_events.append({"t": t, "source": "runner", "type": "service_restarted", "process": name,
                                         "exit_code": code, "restart": len(done)})
        self._track_controllers(now)

    def controllers_running(self) -> bool:
        names = [n for n in ("controller", "controller2") if n in self.procs]
        return any(self.procs[n].poll() is None for n in names)

    def _track_controllers(self, now: float) -> None:
        if self.t0 is None:
            return
        t = round(now - self.t0, 6)
        running = self.controllers_running()
        if not running and (not self.no_controller or self.no_controller[-1][1] is not None):
            self.no_controller.append([t, None])
            self.timeline_events.append({"t": t, "source": "runner", "type": "no_controller"})
        elif running and self.no_controller and self.no_controller[-1][1] is None:
            self.no_controller[-1][1] = t

    def _stop_controller(self) -> None:
        if getattr(self, "_controller_stopping", False):
            return
        self._controller_stopping = True
        for name in ("controller", "controller2"):
            proc = self.procs.get(name)
            if proc is not None and proc.poll() is None:
                proc.send_signal(signal.SIGTERM)

    def _progress(self, tty: bool, final: bool = False) -> None:
        if self.quiet:
            return
        st = self.plant_status() or {}
        total = self.scenario.duration_s
        t = min(st.get("t_sim", 0.0), total)
        width = 30
        filled = int(width * t / total) if total else width
        line = (f"[{'#' * filled}{'.' * (width - filled)}] t={t:6.2f}/{total:.2f} s  late={st.get('late_steps', 0)}"
                f"  meas_tx={st.get('meas_tx', 0)}  ctrl_rx={st.get('ctrl_rx', 0)}"
                f"  visc={','.join(st.get('streaming', [])) or '-'}")
        if tty:
            print("\r" + line.ljust(110), end="\n" if final else "", flush=True)
        else:
            print(line, flush=True)

    # ------------------------------------------------------------------ teardown
    def stop_services(self) -> None:
        """Stop the services so they write their statistics (SIGTERM/EOF, then SIGKILL)."""
        for name, proc in self.procs.items():
            code = proc.poll()
            if code is not None and name != "plant" and not (name.endswith(".fuzz") and code == 0):
                self.exited_early[name] = code  # died before the end (crash, or a timeline kill)
        # the SDN app first, so the end of the plant's packets is not mistaken for a failure
        order = ["owfcc.owfcc", "controller", "controller2", "plant"] + [n for n in self.procs if n.endswith(".sdc")] + \
                [n for n in self.procs if n.endswith(".tcpdump")]
        for name in order:
            proc = self.procs.get(name)
            if proc is None or proc.poll() is not None:
                continue
            if proc.stdin:
                try:
                    proc.stdin.close()
                except OSError:
                    pass
            if not (name.startswith("controller") and getattr(self, "_controller_stopping", False)):
                proc.send_signal(signal.SIGINT if name.endswith(".tcpdump") else signal.SIGTERM)
            if name.startswith("controller"):
                try:
                    proc.wait(timeout=5)
                except subprocess.TimeoutExpired:
                    proc.kill()
        deadline = time.time() + 5
        for proc in self.procs.values():
            try:
                proc.wait(timeout=max(0.1, deadline - time.time()))
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()

    def teardown(self) -> None:
        try:
            self.stop_services()
        finally:
            if self.net is not None:
                try:
                    self.net.stop()
                except Exception as exc:  # noqa: BLE001 - teardown must go on
                    print(f"sdvisc: mininet stop failed ({exc}); cleaning up", file=sys.stderr)
            cleanup.clean()


def run_scenario(scenario: Scenario, out_dir: str | Path, *, cli: bool = False, quiet: bool = False,
                 source: str | None = None) -> dict:
    """Run ``scenario``; returns the summary (also written to ``out_dir/summary.json``)."""
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
    run = Run(scenario, out, quiet=quiet)
    completed = False
    try:
        run.build()
        run.start_services()
        if cli:
            from scenarios.cli_ext import TestbedCLI

            player = threading.Thread(target=run.play, daemon=True)
            player.start()
            TestbedCLI(run.net, run=run)
            player.join(timeout=0.1)
            completed = run.finished.is_set()
        else:
            run.play()
            completed = True
    finally:
        try:
            run.teardown()
        finally:
            for s, handler in previous.items():
                signal.signal(s, handler)
            summary = build_summary(run, completed=completed, source=source)
            (out / "summary.json").write_text(json.dumps(summary, indent=1))
    return summary
