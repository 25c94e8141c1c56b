"""The run's processes: started (in the root namespace or a Mininet host), fed JSON-line commands,
waited for, restarted after a crash, and stopped so that they write their statistics.

A service that exits without being told to (a crash) is restarted, at most :data:`MAX_RESTARTS`
times per run (event ``service_restarted``, ``summary.json`` ``restarts``); a planned kill of the
timeline never is. While no SDN application runs at all, the interval is recorded
(``no_controller``) so that recoveries can say why nothing reacted.
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

from host_tools.cleanup import RUN_MARKER
from scenarios.remote_process import RemoteProcess, popen_in
from sdvisc.netns import cpu_seconds_of

MAX_RESTARTS = 3  # per service and run
RESTARTABLE = (".sdc", "owfcc.owfcc", "controller", "controller2")  # the plant is the run's clock: never
CONTROLLERS = ("controller", "controller2")
READY_TIMEOUT_S = 120.0


OVS_PIDFILE = "/var/run/openvswitch/ovs-vswitchd.pid"


class RunError(RuntimeError):
    """The run could not be set up or did not complete."""


class Processes:
    """Every process of one run (see the module docstring); ``record`` adds a runner event."""

    def __init__(self, out: Path, record) -> None:
        self.out = out
        self.record = record
        self.procs: dict[str, subprocess.Popen | RemoteProcess] = {}
        self.specs: dict[str, tuple] = {}  # how each service was started (to restart it)
        self.killed: set[str] = set()  # planned kills: never restarted
        self.restarts: dict[str, list[dict]] = {}
        self.exited_early: dict[str, int] = {}
        self.no_controller: list[list[float | None]] = []  # [t_from, t_to or None]: no SDN app running
        self.controllers_stopping = False
        self._stdin_lock = threading.Lock()
        self.extra_cpu = None  # () -> {name: CPU seconds} of processes not started here (a server's ovs-vswitchd)

    def start(self, name: str, args: list[str], host=None, stdin=None, mode: str = "w") -> subprocess.Popen:
        """Start ``args`` as ``name`` (in Mininet ``host``'s namespace if given); output to ``name.log``."""
        self.specs[name] = (args, host, stdin)
        log = open(self.out / f"{name}.log", mode)  # noqa: SIM115 - owned by the process
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        # one BLAS thread per service: a multi-threaded OpenBLAS call (the plant refactorising its
        # network at a fault) waits for its worker threads on a busy 2-core machine, 5-20 ms instead
        # of ~1 ms, longer than a step at k = 8 (docs/sdc.md, through the network)
        env.setdefault("OPENBLAS_NUM_THREADS", "1")
        env.update([RUN_MARKER.split("=")])  # the clean-up stops only what a run started (host_tools.cleanup)
        if host is None:
            proc = subprocess.Popen(args, stdin=stdin, stdout=log, stderr=subprocess.STDOUT, env=env,
                                    start_new_session=True)
        else:  # (a host on another server: over ssh, scenarios/remote_process.py)
            proc = popen_in(host, args, env=env, pidfile=self.out / f"{name}.pid", stdin=stdin, stdout=log,
                            stderr=subprocess.STDOUT)
        self.procs[name] = proc
        return proc

    def alive(self, name: str) -> bool:
        proc = self.procs.get(name)
        return proc is not None and proc.poll() is None

    def send(self, name: str, obj: dict) -> bool:
        """One JSON-line command to ``name``'s stdin; False if it is not running."""
        proc = self.procs.get(name)
        if proc is None or proc.poll() is not None or proc.stdin is None:
            return False
        with self._stdin_lock:
            try:
                proc.stdin.write((json.dumps(obj) + "\n").encode())
                proc.stdin.flush()
            except (BrokenPipeError, OSError):
                return False
        return True

    def kill(self, name: str, *, crash: bool) -> bool:
        """SIGKILL ``name``: a planned stop (never restarted) or, with ``crash``, a crash."""
        proc = self.procs.get(name)
        if proc is None or proc.poll() is not None:
            return False
        if not crash:
            self.killed.add(name)
        proc.kill()
        return True

    def wait_ready(self, name: str, ready_file: str, what: str, timeout_s: float = READY_TIMEOUT_S) -> dict:
        """Wait for a service's ``ready_file`` (JSON, written atomically once it has warmed up: its
        first run on a machine compiles numba code, some seconds); returns its content."""
        ready, end = self.out / ready_file, time.time() + timeout_s
        while True:
            try:
                return json.loads(ready.read_text())
            except (OSError, ValueError):
                pass
            log = self.out / f"{name}.log"
            if self.procs[name].poll() is not None:
                raise RunError(f"{what} exited during start-up; see {log}")
            if time.time() > end:
                raise RunError(f"{what} not ready after {timeout_s:.0f} s; see {log}")
            time.sleep(0.02)

    def wait_listening(self, name: str, port: int, what: str, timeout_s: float, host: str = "127.0.0.1") -> None:
        """Wait until ``name`` accepts TCP connections on ``host``:``port`` (an SDN app's OpenFlow port)."""
        deadline = time.time() + timeout_s
        while time.time() < deadline:
            if self.procs[name].poll() is not None:
                raise RunError(f"{what} exited with {self.procs[name].returncode}; see {self.out}/{name}.log")
            with socket.socket() as s:
                if s.connect_ex((host, port)) == 0:
                    return
            time.sleep(0.1)
        raise RunError(f"{what} did not listen on port {port} within {timeout_s:.0f} s")

    # ------------------------------------------------------------------ while the run plays
    def supervise(self, t: float | None) -> None:
        """Restart what crashed; track whether any SDN application runs (``t``: scenario time)."""
        if self.controllers_stopping:
            return
        for name, proc in list(self.procs.items()):
            code = proc.poll()
            if code is None or name in self.killed or not name.endswith(RESTARTABLE):
                continue
            done = self.restarts.setdefault(name, [])
            if len(done) >= MAX_RESTARTS:
                continue
            args, host, stdin = self.specs[name]
            try:
                self.start(name, args, host=host, stdin=stdin, mode="a")
            except OSError as exc:
                done.append({"t": t, "exit_code": code, "error": str(exc)})
                continue
            done.append({"t": t, "exit_code": code})
            self.record({"t": t, "source": "runner", "type": "service_restarted", "process": name,
                         "exit_code": code, "restart": len(done)})
        if t is not None and any(n in self.procs for n in CONTROLLERS):
            self._track_controllers(t)

    def controllers_running(self) -> bool:
        return any(self.alive(n) for n in CONTROLLERS if n in self.procs)

    def _track_controllers(self, t: float) -> None:
        running = self.controllers_running()
        if not running and (not self.no_controller or self.no_controller[-1][1] is not None):
            self.no_controller.append([t, None])
            self.record({"t": t, "source": "runner", "type": "no_controller"})
        elif running and self.no_controller and self.no_controller[-1][1] is None:
            self.no_controller[-1][1] = t

    def stop_controllers(self) -> None:
        """The scenario is over: no decisions on the plant's last packets."""
        if self.controllers_stopping:
            return
        self.controllers_stopping = True
        for name in CONTROLLERS:
            if self.alive(name):
                self.procs[name].send_signal(signal.SIGTERM)

    def cpu_seconds(self) -> dict[str, float]:
        """CPU time (user + system, s) used so far by each running process, and by Open vSwitch's
        ovs-vswitchd (all switches of the run), read from /proc."""
        pids = {name: proc.pid for name, proc in self.procs.items() if proc.poll() is None}
        try:
            pids["ovs-vswitchd"] = int(Path(OVS_PIDFILE).read_text().split()[0])
        except (OSError, ValueError, IndexError):
            pass
        out = {}
        for name, pid in pids.items():
            proc = self.procs.get(name)
            seconds = proc.cpu_seconds() if isinstance(proc, RemoteProcess) else cpu_seconds_of(pid)
            if seconds is not None:
                out[name] = seconds
        if self.extra_cpu is not None:
            out.update(self.extra_cpu())
        return out

    # ------------------------------------------------------------------ the end
    def stop_all(self, waited: dict[str, float] | None = None) -> None:
        """Stop every process so it writes its statistics (SIGTERM/EOF, then SIGKILL); ``waited``
        gets the wall seconds spent waiting for each controller and for the rest."""
        waited = {} if waited is None else waited
        for name, proc in self.procs.items():
            code = proc.poll()
            asked_to_stop = name in CONTROLLERS and self.controllers_stopping  # SIGTERMed at the end: exits at once
            if code is not None and name != "plant" and not asked_to_stop and not (name.endswith(".fuzz") and code == 0):
                self.exited_early[name] = code  # died before the end (crash, or a timeline kill)
        # the SDN app first, so the end of the plant's packets is not mistaken for a failure
        order = (["owfcc.owfcc", *CONTROLLERS, "plant"] + [n for n in self.procs if n.endswith(".sdc")]
                 + [n for n in self.procs if n.endswith((".tcpdump", ".impair"))])
        for name in order:
            proc = self.procs.get(name)
            if proc is None or proc.poll() is not None:
                continue
            if proc.stdin:
                try:
                    proc.stdin.close()
                except OSError:
                    pass
            if not (name in CONTROLLERS and self.controllers_stopping):
                proc.send_signal(signal.SIGINT if name.endswith(".tcpdump") else signal.SIGTERM)
            if name in CONTROLLERS:
                started = time.perf_counter()
                try:
                    proc.wait(timeout=5)
                except subprocess.TimeoutExpired:
                    proc.kill()
                waited[name] = round(time.perf_counter() - started, 3)
        started = time.perf_counter()
        deadline = time.time() + 5
        for proc in self.procs.values():
            try:
                proc.wait(timeout=max(0.1, deadline - time.time()))
            except subprocess.TimeoutExpired:
                proc.kill()
                try:
                    proc.wait(timeout=5)
                except subprocess.TimeoutExpired:  # (D state): left to the clean-up, which reports it
                    print(f"sdvisc: a process (pid {proc.pid}) did not end 5 s after SIGKILL", file=sys.stderr)
        waited["others"] = round(time.perf_counter() - started, 3)
