"""The interactive session's part of the testbed CLI (a mixin of :class:`scenarios.cli_ext.TestbedCLI`):
feedback printed above the prompt without breaking the line being typed, the session's end,
``kill``, ``events`` and ``watch``. Each ``do_*`` docstring is its ``help`` text.
"""

from __future__ import annotations

import select
import sys
import threading

from scenarios.feedback import event_line, watch_line

WATCH_EVERY_S = 0.5  # wall seconds between two lines of `watch`
KILLABLE = {"sdc": ".sdc", "owfcc": ".owfcc"}


class SessionCommands:
    """See the module docstring; expects ``self.testbed`` (the Run) and ``self.session``."""

    session = None
    eof = False  # stdin closed (not `exit`)
    at_prompt = False
    _print_lock = threading.Lock()

    # ------------------------------------------------------------------ printing while the user types
    def notify(self, line: str) -> None:
        """Print ``line`` for the user: above the prompt and what is typed so far, if waiting for input."""
        with self._print_lock:
            if self.at_prompt and sys.stdout.isatty():
                try:
                    import readline

                    typed = readline.get_line_buffer()
                except ImportError:
                    typed = ""
                sys.stdout.write(f"\r\x1b[K{line}\n{self.prompt}{typed}")
            else:
                sys.stdout.write(line + "\n")
            sys.stdout.flush()

    def preloop(self):
        self.at_prompt = True

    def precmd(self, line):
        self.at_prompt = False
        return line

    def postcmd(self, stop, line):
        self.at_prompt = not stop
        return stop

    def run(self):
        """Mininet's loop, ended also by the session's end (a SIGINT from the player thread)."""
        if self.session is None:
            return super().run()
        self.session.cli_active = True
        try:
            while not self.session.ended.is_set():
                try:
                    self.cmdloop()
                    break
                except KeyboardInterrupt as exc:
                    if exc.args:  # SIGTERM or SIGHUP (the runner's handler names the signal): end the run
                        raise
                    if self.session.ended.is_set():
                        print(flush=True)  # leave the unfinished input line
                        break
                    self.notify("\nInterrupt (type exit to end the session)")
        finally:
            self.session.cli_active = False
            self.at_prompt = False

    def do_EOF(self, line):  # noqa: N802 - cmd's name for end of input
        """EOF (Ctrl-D): end the CLI (with --cli-duration the session then runs to its end)."""
        self.eof = True
        return self.do_exit(line)

    # ------------------------------------------------------------------ commands
    def do_kill(self, line):
        """kill HOST [sdc|owfcc] [crash] | kill controller|controller2 [crash]: SIGKILL a service, as a
        timeline `kill` does (recorded; with `crash` the runner restarts it, as after a real crash)."""
        parts = line.split()
        crash = "crash" in parts
        parts = [p for p in parts if p != "crash"]
        if not parts or len(parts) > 2:
            print("usage: kill HOST [sdc|owfcc] [crash] | kill controller|controller2 [crash]")
            return
        if parts[0].startswith("controller"):
            host, process, name = None, parts[0], parts[0]
        else:
            host = parts[0]
            process = parts[1] if len(parts) == 2 else ("owfcc" if host == "owfcc" else "sdc")
            name = f"{host}{KILLABLE.get(process, '.' + process)}"
        if not self.testbed.processes.alive(name):
            running = sorted(n for n in self.testbed.procs if self.testbed.processes.alive(n) and n != "plant")
            print(f"no running {name}; running services: {', '.join(running)}")
            return
        t = round(self.session.now() if self.session else 0.0, 6)
        record = {"t": t, "source": "cli", "type": "kill", "process": process, "crash": crash}
        if host:
            record["host"] = host
        self.testbed.record(record)
        self.testbed.processes.kill(name, crash=crash)
        print(f"t={t:.3f} s: {'crashed' if crash else 'killed'} {name}")

    def do_events(self, line):
        """events [N]: the last N events of the run (default 20), as in events.jsonl."""
        if self.session is None:
            print("events: only in an interactive session")
            return
        try:
            n = int(line.strip() or 20)
        except ValueError:
            print("usage: events [N]")
            return
        self.session.poll()
        for e in self.session.recent_events(n):
            print(event_line(e))

    def do_watch(self, line):
        """watch WT: follow one turbine (packets/s, one-way delay of its control packets, V, Q, f,
        T2/T3, path) until Enter."""
        wt = line.strip()
        status = self.testbed.plant_status() or {}
        if wt not in status.get("turbines", {}):
            print(f"usage: watch WT (turbines: {', '.join(sorted(status.get('turbines', {}))) or '-'})")
            return
        print(f"watching {wt}; press Enter to stop")
        previous = None
        while not (self.session is not None and self.session.ended.is_set()):
            status = self.testbed.plant_status() or {}
            tables = (self.testbed.sdn_state() or {}).get("tables", {})
            if previous is not None:
                self.notify(watch_line(wt, status, previous, tables))
            previous = status
            ready, _, _ = select.select([self.stdin], [], [], WATCH_EVERY_S)
            if ready:
                self.stdin.readline()
                break
