"""The offshore wind-farm control centre (OWFCC): asks the SDN application for ViSC service.

``python -m sdvisc.owfcc --config FILE`` runs in the ``owfcc`` Mininet host. It reads commands as
JSON lines on stdin (the runner plays the scenario timeline into it)::

    {"cmd": "visc_on", "wt": "wt1_1", "params": {"h": 3.0, "m_q": 0.02}}
    {"cmd": "visc_off", "wt": "wt1_1"}
    {"cmd": "set_params", "wt": "wt1_1", "params": {"v_ref": 1.04}}

and sends each as a ``REQUEST`` to the SDN application's virtual IP, re-sending (same ``req_id``)
when no ``REPLY`` arrives within ``retry_s``. Every request and reply is logged to
``owfcc_events.jsonl`` in the output directory with its wall time and round-trip time.
"""

from __future__ import annotations

import argparse
import json
import select
import socket
import sys
import time
from pathlib import Path

from sdvisc import wire
from sdvisc.jsonlines import JsonLineReader

COMMANDS = {"visc_on": wire.Command.VISC_ON, "visc_off": wire.Command.VISC_OFF,
            "set_params": wire.Command.SET_PARAMS}
PARAM_BITS = {"h": wire.ParamMask.H, "d": wire.ParamMask.D, "m_q": wire.ParamMask.M_Q,
              "v_ref": wire.ParamMask.V_REF, "q_ref": wire.ParamMask.Q_REF, "supp": wire.ParamMask.SUPP}


def request_values(req_id: int, command: dict) -> dict:
    """REQUEST fields for one stdin command (unknown parameter names raise ValueError)."""
    cmd = COMMANDS[command["cmd"]]
    values = {"req_id": req_id, "cmd": int(cmd), "wt": wire.turbine_id(*wire.parse_turbine(command["wt"])),
              "sdc_ip": 0, "mask": 0, "h": 0.0, "d": 0.0, "m_q": 0.0, "v_ref": 0.0, "q_ref": 0.0, "supp": 0}
    for name, value in (command.get("params") or {}).items():
        if name not in PARAM_BITS:
            raise ValueError(f"unknown ViSC parameter {name!r}; known: {sorted(PARAM_BITS)}")
        values[name] = int(value) if name == "supp" else float(value)
        values["mask"] |= int(PARAM_BITS[name])
    return values


class Owfcc:
    def __init__(self, cfg: dict) -> None:
        self.cfg = cfg
        self.vip = (cfg["controller_vip"], wire.PORT_CONTROLLER)
        self.header = bool(cfg.get("header", True))
        self.retry_s = float(cfg.get("retry_s", 0.5))
        self.max_tries = int(cfg.get("max_tries", 4))
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("0.0.0.0", wire.PORT_OWFCC))
        self.sock.setblocking(False)
        self.log = open(Path(cfg["out_dir"]) / "owfcc_events.jsonl", "a", buffering=1)  # noqa: SIM115
        self.pending: dict[int, dict] = {}
        self.next_id = 1
        self.rx_stats = wire.DecodeStats()

    def _log(self, **event) -> None:
        self.log.write(json.dumps({"t_wall": time.time(), **event}) + "\n")

    def _send(self, req_id: int) -> None:
        p = self.pending[req_id]
        p["tries"] += 1
        p["t_sent"] = time.time()
        hdr = wire.Header.now(req_id) if self.header else None
        self.sock.sendto(wire.encode(wire.MsgType.REQUEST, p["values"], header=hdr), self.vip)

    def submit(self, command: dict) -> None:
        req_id = self.next_id
        self.next_id += 1
        try:
            values = request_values(req_id, command)
        except (KeyError, ValueError) as exc:
            self._log(type="owfcc_error", command=command, error=str(exc))
            return
        self.pending[req_id] = {"values": values, "command": command, "tries": 0, "t_first": time.time()}
        self._log(type="owfcc_request", req_id=req_id, **{k: command[k] for k in ("cmd", "wt")},
                  params=command.get("params") or {})
        self._send(req_id)

    def _on_reply(self) -> None:
        while True:
            try:
                data, _ = self.sock.recvfrom(2048)
            except BlockingIOError:
                return
            msg = self.rx_stats.decode(data, header=self.header)
            if msg is None or msg.type != wire.MsgType.REPLY:
                continue
            p = self.pending.pop(msg["req_id"], None)
            if p is None:
                continue
            self._log(type="owfcc_reply", req_id=msg["req_id"], wt=p["command"]["wt"], cmd=p["command"]["cmd"],
                      status=wire.Status(msg["status"]).name, rtt_ms=(time.time() - p["t_first"]) * 1e3,
                      tries=p["tries"])

    def _retry(self) -> None:
        now = time.time()
        for req_id, p in list(self.pending.items()):
            if now - p["t_sent"] < self.retry_s:
                continue
            if p["tries"] >= self.max_tries:
                self.pending.pop(req_id)
                self._log(type="owfcc_timeout", req_id=req_id, wt=p["command"]["wt"], cmd=p["command"]["cmd"])
            else:
                self._send(req_id)

    def run(self) -> None:
        poller = select.epoll()
        commands = JsonLineReader(sys.stdin.fileno())
        poller.register(commands.fd, select.EPOLLIN)
        poller.register(self.sock.fileno(), select.EPOLLIN)
        while commands.open or self.pending:
            for fd, _ in poller.poll(0.05):
                if fd == commands.fd:
                    for command in commands.read():
                        self.submit(command)
                    if not commands.open:
                        poller.unregister(commands.fd)
                else:
                    self._on_reply()
            self._retry()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sdvisc.owfcc", description=__doc__)
    parser.add_argument("--config", required=True)
    args = parser.parse_args(argv)
    owfcc = Owfcc(json.loads(Path(args.config).read_text()))
    try:
        owfcc.run()
    except KeyboardInterrupt:
        pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
