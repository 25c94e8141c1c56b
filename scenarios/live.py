"""An interactive session (``sdvisc run --cli``): the scenario stays live until the user quits.

The timeline plays as written; when it ends the plant (started open-ended), the SDC(s) and the SDN
app go on, paced at the run's time scale, until the user types ``exit`` (or ``--cli-duration``
seconds of simulated time have passed, or stdin closes and ``--cli-duration`` then ends it). The
:class:`EventTail` reads the run's events as the components write them (the files that
``events.jsonl`` is made of at the end, plus the runner's own records), a notifier thread turns
them into lines (:mod:`scenarios.feedback`) printed above the prompt, and the optional live view
(:mod:`scenarios.web`) shows the same.
"""

from __future__ import annotations

import json
import signal
import threading
import time
from pathlib import Path

from scenarios.cli_ext import TestbedCLI
from scenarios.feedback import Feedback
from scenarios.processes import RunError
from scenarios.summary import on_run_clock
from scenarios.web import LiveView

EVENT_FILES = {"sdn_events.jsonl": "sdn_app", "sdn2_events.jsonl": "sdn_app2", "owfcc_events.jsonl": "owfcc",
               "plant_events.jsonl": "plant"}
NOTIFY_EVERY_S = 0.1  # wall seconds between two looks at the event files
MAX_EVENTS_KEPT = 100_000
PLAY_JOIN_S = 60.0  # wall seconds the session waits for the plant and the controllers to stop


class EventTail:
    """New events since the last :meth:`read`, each with ``t`` in scenario seconds and ``source``
    (as in ``events.jsonl``): from the components' ``*_events.jsonl`` files (complete lines only)
    and from ``runner_events`` (the runner's list of timeline and CLI records)."""

    def __init__(self, out_dir: Path, t0: float, runner_events: list[dict]) -> None:
        self.out = Path(out_dir)
        self.t0 = t0
        self.runner_events = runner_events
        self.offsets = dict.fromkeys(EVENT_FILES, 0)
        self.runner_index = 0

    def read(self) -> list[dict]:
        new = []
        for name, source in EVENT_FILES.items():
            try:
                with open(self.out / name, "rb") as fh:
                    fh.seek(self.offsets[name])
                    chunk = fh.read()
            except OSError:
                continue
            complete = chunk[:chunk.rfind(b"\n") + 1]
            self.offsets[name] += len(complete)
            for line in complete.splitlines():
                try:
                    e = json.loads(line)
                except ValueError:
                    continue
                on_run_clock(e, self.t0)  # the SDN app's other times are clock readings too
                e.setdefault("source", source)
                new.append(e)
        count = len(self.runner_events)
        new += [dict(e) for e in self.runner_events[self.runner_index:count]]
        self.runner_index = count
        new.sort(key=lambda e: e.get("t", 0.0))
        return new


class Session:
    """See the module docstring. ``run``: a :class:`scenarios.runner.Run` whose ``session`` is this."""

    def __init__(self, run, *, cli_duration_s: float | None = None, web_port: int | None = None) -> None:
        self.run = run
        self.cli_duration_s = cli_duration_s
        self.web_port = web_port
        self.stop_requested = threading.Event()  # the user typed exit
        self.ended = threading.Event()  # the plant has stopped (or the run failed)
        self.plant_stopped = False
        self.error: BaseException | None = None
        self.events: list[dict] = []
        self.lines: list[str] = []  # the feedback shown so far (also on the live view)
        self.feedback = Feedback()
        self.cli = None  # the TestbedCLI, once it runs
        self.cli_active = False  # its prompt loop runs (a SIGINT ends it once the session is over)
        self.web = None
        self.lock = threading.Lock()

    # ------------------------------------------------------------------ called by Run.play
    def ending(self, t: float) -> bool:
        """True once the session is over (exit typed, or ``cli_duration_s`` reached at scenario
        time ``t``); the first time, tells the plant to stop."""
        over = self.stop_requested.is_set() or (self.cli_duration_s is not None and t >= self.cli_duration_s)
        if over and not self.plant_stopped:
            self.plant_stopped = True
            self.run.command("plant", {"type": "stop"})
        return over

    def now(self) -> float:
        """Scenario time now (simulated seconds from t = 0)."""
        return self.run.clock.now() - self.run.t0

    # ------------------------------------------------------------------ the session
    def interact(self) -> bool:
        """Run the CLI until the session ends; returns whether the run completed."""
        run = self.run
        self.tail = EventTail(run.out, run.t0, run.timeline_events)
        player = threading.Thread(target=self._play, name="sdvisc-player", daemon=True)
        notifier = threading.Thread(target=self._notify_loop, name="sdvisc-feedback", daemon=True)
        try:
            if self.web_port is not None:
                try:
                    self.web = LiveView(run, self, self.web_port).start()
                except OSError as exc:
                    raise RunError(f"--web {self.web_port}: cannot listen on 127.0.0.1:{self.web_port} ({exc.strerror}); "
                                   "choose another port") from exc
                print(f"sdvisc: live view at {self.web.url} (this machine only)", flush=True)
            sc = run.scenario
            plays = f"the timeline plays until t = {sc.duration_s:g} s, then " if sc.duration_s else ""
            until = f"until exit or t = {self.cli_duration_s:g} s" if self.cli_duration_s else "until you type exit"
            print(f"sdvisc: interactive session: {plays}the farm stays live {until} "
                  f"(help: status, events, watch WT, link A B down, kill HOST, visc WT on)", flush=True)
            player.start()
            notifier.start()
            cli = TestbedCLI(run.net, run=run, session=self)
            if cli.eof and self.cli_duration_s is not None and not self.ended.is_set():
                print(f"sdvisc: stdin closed; the session goes on until t = {self.cli_duration_s:g} s", flush=True)
                self.ended.wait()
            print(f"sdvisc: session ended at t = {self.now():.2f} s; stopping the services and the network …", flush=True)
        finally:
            self.stop_requested.set()
            if player.ident:
                player.join(timeout=PLAY_JOIN_S)
            self.ended.set()
            if notifier.ident:
                notifier.join(timeout=2.0)
            if self.web is not None:
                self.web.stop()
        if self.error is not None:
            raise self.error
        return run.finished.is_set()

    def settle_duration(self) -> None:
        """The run's duration becomes the session's (what the plant ran), for ``summary.json``."""
        run = self.run
        t_end = (run.plant_status() or {}).get("t_sim")
        if t_end or run.scenario.duration_s is None:
            run.scenario = run.scenario.model_copy(update={"duration_s": round(float(t_end or 0.0), 6)})

    def _play(self) -> None:
        try:
            self.run.play()
        except BaseException as exc:  # noqa: BLE001 - re-raised in the main thread
            self.error = exc
        finally:
            self.ended.set()
            if not self.stop_requested.is_set() and self.cli_active:  # --cli-duration or a failure: end the prompt
                why = "the run failed" if self.error else f"t = {self.cli_duration_s:g} s (--cli-duration)"
                self.say(f"sdvisc: the session is over: {why}")
                signal.pthread_kill(threading.main_thread().ident, signal.SIGINT)

    def _notify_loop(self) -> None:
        while not self.ended.is_set():
            self.poll()
            time.sleep(NOTIFY_EVERY_S)
        self.poll()

    def poll(self) -> None:
        """Read new events; show what followed the actions."""
        with self.lock:
            new = self.tail.read()
            self.events += new
            if len(self.events) > MAX_EVENTS_KEPT:
                del self.events[:len(self.events) - MAX_EVENTS_KEPT]
            lines = self.feedback.feed(new, self.now())
            self.lines += lines
        for line in lines:
            self.say(line)

    def say(self, line: str) -> None:
        if self.cli is not None:
            self.cli.notify(line)
        else:
            print(line, flush=True)

    def recent_events(self, n: int) -> list[dict]:
        with self.lock:
            return self.events[-n:] if n > 0 else []


def check_open_ended(duration_s: float | None, cli: bool) -> None:
    """An open-ended scenario (``duration_s: null``) is for interactive sessions only."""
    if duration_s is None and not cli:
        raise RunError("duration_s is open-ended (null or --duration inf): that needs --cli, whose `exit` "
                       "(or --cli-duration S) ends the session")
