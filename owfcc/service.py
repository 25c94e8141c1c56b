"""The offshore wind-farm control centre (OWFCC): asks the SDN application for ViSC service.

``python -m owfcc.service --config FILE`` runs in the ``owfcc`` Mininet host. It reads commands as
JSON lines on stdin (the runner plays the scenario timeline into it)::

    {"cmd": "visc_on", "wt": "wt1_1", "params": {"h": 3.0, "m_q": 0.02}}
    {"cmd": "visc_off", "wt": "wt1_1"}
    {"cmd": "set_params", "wt": "wt1_1", "params": {"v_ref": 1.04}}

and stops once stdin ends and every request is answered or given up. A deployed OWFCC (``sdvisc
owfcc --config F``, docs/real-devices.md) takes the same commands from its configuration's
``schedule`` (each at its simulated time after start) and from a Unix datagram socket
(``command_socket``; ``sdvisc owfcc-send``: one or more JSON lines per datagram, each answered with
``{"req_id": N}`` or ``{"error": ...}`` to a sender that has an address); with ``stdin_commands:
false`` it does not read stdin and runs until SIGTERM.

and sends each as a ``REQUEST`` to the SDN application's virtual IP, re-sending (same ``req_id``)
when no ``REPLY`` arrives within ``retry_s``. Every request and reply is logged to
``owfcc_events.jsonl`` in the output directory with its wall time and round-trip time.

A received datagram that is not the awaited ``REPLY`` to a pending request is dropped and counted
(``rx_rejected`` and ``rx_reject_<reason>``, see :data:`RX_REASONS`); a late answer to a request
already answered or given up (e.g. to a retry) is only counted (``replies_late``). The counters
are written to ``owfcc_stats.json`` when the OWFCC stops.
"""

from __future__ import annotations

import json
import os
import select
import signal
import socket
import sys
import traceback
from pathlib import Path

from sdvisc import wire
from sdvisc.config import OwfccConfig, ScheduledCommand, service_config
from sdvisc.jsonlines import JsonLineReader, write_json_atomic
from sdvisc.vocabulary import BLANK_REQUEST_PARAMS, VISC_PARAMS, param_word

COMMANDS = {"visc_on": wire.Command.VISC_ON, "visc_off": wire.Command.VISC_OFF,
            "set_params": wire.Command.SET_PARAMS}
RX_REASONS: tuple[str, ...] = wire.REJECT_REASONS + ("unexpected_type", "unknown_req_id", "mismatch", "internal")
"""Why a received datagram was dropped: the wire reasons (not a valid testbed message);
``unexpected_type``: a valid message other than REPLY; ``unknown_req_id``: a REPLY to a request id
never issued; ``mismatch``: a REPLY whose ``wt`` or ``cmd`` is not that of the pending request with
its id (the request stays pending); ``internal``: handling it raised (logged once to stderr)."""
PARAM_BITS = VISC_PARAMS


def request_values(req_id: int, command: dict) -> dict:
    """REQUEST fields for one stdin command (unknown parameter names raise ValueError)."""
    cmd = COMMANDS[command["cmd"]]
    values = {"req_id": req_id, "cmd": int(cmd), "wt": wire.turbine_id(*wire.parse_turbine(command["wt"])),
              "sdc_ip": 0, **BLANK_REQUEST_PARAMS}
    for name, value in (command.get("params") or {}).items():
        if name not in PARAM_BITS:
            raise ValueError(f"unknown ViSC parameter {name!r}; known: {sorted(PARAM_BITS)}")
        values[name] = param_word(name, value)
        values["mask"] |= int(PARAM_BITS[name])
    return values


class Owfcc:
    def __init__(self, cfg: OwfccConfig, sock: socket.socket | None = None,
                 controller: tuple[str, int] | None = None) -> None:
        self.cfg = cfg
        self.vip = controller or (cfg.controller_vip, wire.PORT_CONTROLLER)  # (tests hand in their own)
        self.header = cfg.header
        self.clock = cfg.clock()  # the run's one clock: retries and logged times in simulated seconds
        self.retry_s = cfg.retry_s
        self.max_tries = cfg.max_tries
        if sock is None:  # (tests hand in their own socket)
            sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            sock.bind((cfg.bind_ip, wire.PORT_OWFCC))
            sock.setblocking(False)
        self.sock = sock
        self.log = open(Path(cfg.out_dir) / "owfcc_events.jsonl", "a", buffering=1)  # noqa: SIM115
        self.pending: dict[int, dict] = {}
        self.next_id = 1
        self.rx_stats = wire.DecodeStats()
        self.counts = {"replies_rx": 0, "replies_late": 0, "rx_rejected": 0}
        self._internal_logged = False
        self.running = True
        self._wake_fd = -1  # run()'s eventfd while it runs, written by stop()
        self.commands_sock = self._open_command_socket(cfg.command_socket) if cfg.command_socket else None

    def _log(self, **event) -> None:
        self.log.write(json.dumps({"t_wall": self.clock.now(), **event}) + "\n")

    def _send(self, req_id: int) -> None:
        p = self.pending[req_id]
        p["tries"] += 1
        p["t_sent"] = self.clock.now()
        hdr = wire.Header.at(req_id, self.clock.now()) if self.header else None
        self.sock.sendto(wire.encode(wire.MsgType.REQUEST, p["values"], header=hdr), self.vip)

    def submit(self, command: dict, **origin) -> int | str:
        """Send one command as a REQUEST: its request id, or why it was refused (logged as an
        ``owfcc_error``). ``origin``: what the request's log entry also says (schedule, socket)."""
        req_id = self.next_id
        try:
            values = request_values(req_id, command)
        except (KeyError, ValueError, TypeError) as exc:
            error = f"{type(exc).__name__}: {exc}" if isinstance(exc, KeyError) else str(exc)
            self._log(type="owfcc_error", command=command, error=error, **origin)
            return error
        self.next_id += 1
        self.pending[req_id] = {"values": values, "command": command, "tries": 0, "t_first": self.clock.now()}
        self._log(type="owfcc_request", req_id=req_id, **{k: command[k] for k in ("cmd", "wt")},
                  params=command.get("params") or {}, **origin)
        self._send(req_id)
        return req_id

    def _on_reply(self) -> None:
        while True:
            try:
                data, _ = self.sock.recvfrom(2048)
            except BlockingIOError:
                return
            except OSError:  # e.g. an ICMP error reported on the socket: nothing to read now
                self.counts["rx_socket_error"] = self.counts.get("rx_socket_error", 0) + 1
                return
            try:  # one bad datagram never stops the OWFCC
                self.receive(data, self.clock.now())
            except Exception as error:  # noqa: BLE001 - counted and logged once
                self._reject("internal")
                if not self._internal_logged:
                    self._internal_logged = True
                    print(f"owfcc: handling a received datagram raised {type(error).__name__}: {error}; dropped "
                          "and counted as rx_reject_internal (further ones are only counted)", file=sys.stderr)
                    traceback.print_exception(type(error), error, error.__traceback__, file=sys.stderr)

    def _reject(self, reason: str) -> None:
        self.counts["rx_rejected"] += 1
        key = "rx_reject_" + reason
        self.counts[key] = self.counts.get(key, 0) + 1

    def receive(self, data: bytes, now: float) -> dict | None:
        """Handle one datagram received at wall time ``now``: the REPLY to a pending request
        completes it (logged; the log entry is returned); anything else is counted and dropped."""
        try:
            msg = wire.decode(data, header=self.header)
        except wire.WireError as error:
            setattr(self.rx_stats, error.reason, getattr(self.rx_stats, error.reason) + 1)
            self._reject(error.reason)
            return None
        self.rx_stats.ok += 1
        if msg.type != wire.MsgType.REPLY:
            self._reject("unexpected_type")
            return None
        req_id = msg["req_id"]
        p = self.pending.get(req_id)
        if p is None:
            if 1 <= req_id < self.next_id:  # ours, already answered or given up: a duplicate or late answer
                self.counts["replies_late"] += 1
            else:
                self._reject("unknown_req_id")
            return None
        if msg["wt"] != p["values"]["wt"] or msg["cmd"] != p["values"]["cmd"]:
            self._reject("mismatch")
            return None
        del self.pending[req_id]
        self.counts["replies_rx"] += 1
        event = {"type": "owfcc_reply", "req_id": req_id, "wt": p["command"]["wt"], "cmd": p["command"]["cmd"],
                 "status": wire.Status(msg["status"]).name,  # a valid code: decode checked it
                 "rtt_ms": (now - p["t_first"]) * 1e3, "tries": p["tries"]}
        self._log(**event)
        return event

    def stats(self) -> dict:
        """Requests issued and still pending, the receive counters and the wire-level outcomes."""
        return {"requests": self.next_id - 1, "pending": len(self.pending), **self.counts,
                "rx_wire": self.rx_stats.as_dict()}

    def _retry(self) -> None:
        now = self.clock.now()
        for req_id, p in list(self.pending.items()):
            if now - p["t_sent"] < self.retry_s:
                continue
            if p["tries"] >= self.max_tries:
                self.pending.pop(req_id)
                self._log(type="owfcc_timeout", req_id=req_id, wt=p["command"]["wt"], cmd=p["command"]["cmd"])
            else:
                self._send(req_id)

    # ------------------------------------------------------------------ a deployed OWFCC's command sources
    @staticmethod
    def _open_command_socket(path: str) -> socket.socket:
        """The Unix datagram socket at ``path`` (a socket left there by an earlier run is replaced)."""
        where = Path(path)
        if where.is_socket():
            where.unlink()
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        sock.bind(path)
        sock.setblocking(False)
        return sock

    def _on_command_datagrams(self) -> None:
        """Every datagram waiting on the command socket: each line a command, each answered."""
        while True:
            try:
                data, sender = self.commands_sock.recvfrom(65536)
            except (BlockingIOError, InterruptedError):
                return
            answers = []
            for line in data.decode(errors="replace").splitlines():
                if not line.strip():
                    continue
                try:
                    command = json.loads(line)
                except json.JSONDecodeError as exc:
                    command, outcome = line, f"not JSON: {exc}"
                    self._log(type="owfcc_error", command=line, error=outcome, source="socket")
                else:
                    outcome = (self.submit(command, source="socket") if isinstance(command, dict)
                               else "a command is a JSON object")
                answers.append({"req_id": outcome} if isinstance(outcome, int) else {"error": outcome})
            if sender:  # (an unnamed sender cannot be answered)
                try:
                    self.commands_sock.sendto("".join(json.dumps(a) + "\n" for a in answers).encode(), sender)
                except OSError:
                    pass

    def _due(self, schedule: list[ScheduledCommand], t_start: float) -> float | None:
        """Send the scheduled commands whose time has come; the simulated seconds to the next one."""
        elapsed = self.clock.now() - t_start
        while schedule and schedule[0].t_s <= elapsed:
            entry = schedule.pop(0)
            self.submit(entry.model_dump(exclude={"t_s"}), source="schedule", t_s=entry.t_s, t_run=elapsed)
        return schedule[0].t_s - elapsed if schedule else None

    def stop(self) -> None:
        """End :meth:`run` (from a signal handler or another thread)."""
        self.running = False
        if self._wake_fd >= 0:
            os.eventfd_write(self._wake_fd, 1)

    def run(self) -> None:
        """Until stop(); with ``stdin_commands``, also until stdin ends, the schedule is sent and
        no request is pending (the runner's OWFCC)."""
        self._wake_fd = os.eventfd(0, os.EFD_NONBLOCK | os.EFD_CLOEXEC)
        poller = select.epoll()
        commands = JsonLineReader(sys.stdin.fileno()) if self.cfg.stdin_commands else None
        if commands is not None:
            poller.register(commands.fd, select.EPOLLIN)
        poller.register(self.sock.fileno(), select.EPOLLIN)
        poller.register(self._wake_fd, select.EPOLLIN)
        if self.commands_sock is not None:
            poller.register(self.commands_sock.fileno(), select.EPOLLIN)
        schedule = sorted(self.cfg.schedule, key=lambda entry: entry.t_s)
        t_start = self.clock.now()
        try:
            while self.running and (commands is None or commands.open or self.pending or schedule):
                wait_s = self._due(schedule, t_start)
                wait_s = 0.05 if wait_s is None else min(0.05, max(0.0, wait_s))
                for fd, _ in poller.poll(self.clock.wall_s(wait_s)):
                    if commands is not None and fd == commands.fd:
                        for command in commands.read():
                            self.submit(command)
                        if not commands.open:
                            poller.unregister(commands.fd)
                    elif fd == self.sock.fileno():
                        self._on_reply()
                    elif self.commands_sock is not None and fd == self.commands_sock.fileno():
                        self._on_command_datagrams()
                self._retry()
        finally:
            poller.close()
            fd, self._wake_fd = self._wake_fd, -1
            os.close(fd)

    def close(self) -> None:
        """Close the log and the command socket (its file removed)."""
        self.log.close()
        if self.commands_sock is not None:
            self.commands_sock.close()
            self.commands_sock = None
            Path(self.cfg.command_socket).unlink(missing_ok=True)


def main(argv: list[str] | None = None) -> int:
    cfg = service_config(OwfccConfig, argv, prog="python -m owfcc.service", process="owfcc", description=__doc__)
    try:
        owfcc = Owfcc(cfg)
    except OSError as exc:  # a port in use, a command socket that cannot be made
        print(f"owfcc: cannot open its sockets (UDP {cfg.bind_ip}:{wire.PORT_OWFCC}, command socket "
              f"{cfg.command_socket}): {exc}", file=sys.stderr)
        return 1
    # the runner (or systemd) stops the OWFCC with SIGTERM: the loop ends, the statistics are written
    signal.signal(signal.SIGTERM, lambda *_: owfcc.stop())
    try:
        owfcc.run()
    except KeyboardInterrupt:
        pass
    finally:
        write_json_atomic(Path(cfg.out_dir) / "owfcc_stats.json", owfcc.stats())
        owfcc.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
