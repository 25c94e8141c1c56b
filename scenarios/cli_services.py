"""``sdvisc sdc | sdn-app | owfcc | gtnet-card | owfcc-send``: one service of the testbed started
from its configuration file, outside Mininet (a lab's SDC PC, controller PC, OWFCC PC; systemd
units in docs/deploy/systemd/, docs/real-devices.md).

Each subcommand validates the configuration first (YAML or JSON, :func:`sdvisc.config.load_config`:
a problem ends it with status 2, every problem of the file on stderr with its key and line), creates
the output directory, opens the log (``--log``, else ``<service>.log`` in the configuration's output
directory) for appending, and then becomes the service: ``os.execve`` of ``python -m <module>
--config <the file>``, stdout and stderr in the log. So systemd's SIGTERM reaches the service itself,
which writes its statistics and ends.
"""

from __future__ import annotations

import importlib
import importlib.util
import json
import os
import socket
import sys
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


@dataclass(frozen=True)
class Service:
    module: str  # python -m <module>
    model: str  # its configuration model in sdvisc.config ("" : the module validates, see gtnet-card)
    short: str  # sdvisc --help
    help: str  # sdvisc <service> --help


def log_name(name: str, cfg) -> str:
    """The default log's name: ``sdc<id>.log`` (two SDCs may share a directory), else ``<subcommand>.log``."""
    return f"sdc{cfg.sdc_id}.log" if name == "sdc" else f"{name}.log"


SERVICES = {
    "sdc": Service("sdc_unit.service", "SdcConfig", "run the SDC unit from its config file (outside Mininet)",
                   "the SDC unit (ViSC laws for the turbines the SDN app starts on it): UDP port 50010; writes "
                   "sdc<id>_ready.json, and sdc<id>_stats.json when stopped (SIGTERM)"),
    "sdn-app": Service("sdn_app", "AppConfig", "run the SDN application from its config file (outside Mininet)",
                       "the SDN application (os-ken): OpenFlow on --ofp-port, the intake socket on controller_vip:"
                       "50000 if intake_socket is set; writes sdn_state.json and sdn_events.jsonl in state_dir"),
    "owfcc": Service("owfcc.service", "OwfccConfig", "run the OWFCC from its config file (outside Mininet)",
                     "the OWFCC: sends the ViSC requests of its schedule and of its command socket (sdvisc "
                     "owfcc-send); writes owfcc_events.jsonl, and owfcc_stats.json when stopped (SIGTERM)"),
    "gtnet-card": Service("plant.card.emulator", "", "run the project's GTNET-SKT card emulator (in place of an RTDS)",
                          "the project's GTNET-SKT card emulator (plant/card/emulator.py): stands in for an RTDS with "
                          "GTNET-SKT cards, one UDP port per turbine; writes gtnet_card_ready.json and "
                          "gtnet_card_stats.json"),
}


def add_parsers(sub) -> None:
    """The service subcommands, added to ``sdvisc``'s subparsers."""
    for name, service in SERVICES.items():
        p = sub.add_parser(name, help=service.short, description=f"{service.help}. Runs `python -m {service.module} "
                           "--config FILE` after validating FILE (exit 2 naming every problem).")
        p.add_argument("--config", required=True, help="the service's configuration, YAML (.yaml/.yml) or JSON")
        p.add_argument("--log", help="append stdout and stderr here (default: <service>.log in the configuration's "
                       "out_dir / state_dir; the sdn-app without a state_dir: the terminal or journal)")
        if name == "sdn-app":
            p.add_argument("--ofp-port", type=int, default=6653, help="OpenFlow listen port (default 6653)")
            p.add_argument("--listen-host", default="0.0.0.0", help="OpenFlow listen address (default 0.0.0.0)")
        p.set_defaults(func=lambda args, name=name: run_service(name, args))
    p = sub.add_parser("owfcc-send", help="send JSON-line commands to a running OWFCC's command socket")
    p.add_argument("--socket", required=True, help="the OWFCC's command_socket path")
    p.add_argument("commands", nargs="+", help='commands, e.g. \'{"cmd": "visc_on", "wt": "wt1_1"}\'')
    p.add_argument("--timeout", type=float, default=2.0, help="seconds to wait for the OWFCC's answer")
    p.set_defaults(func=owfcc_send)


def _fail(name: str, text: str) -> int:
    print(f"sdvisc {name}: {text}", file=sys.stderr)
    return 2


def _validate(service: Service, path: Path):
    """The validated configuration (None for a module that validates its own); ConfigError otherwise."""
    if service.model:
        from sdvisc import config

        return config.load_config(getattr(config, service.model), path)
    loader = getattr(importlib.import_module(service.module), "load_card_config", None)  # at call time
    return loader(path) if loader is not None else None


def run_service(name: str, args) -> int:
    """Validate, prepare the output directory (and the OWFCC's command socket's) and the log, then
    exec the service (see the module docstring)."""
    from sdvisc.config import ConfigError

    service = SERVICES[name]
    path = Path(args.config).resolve()
    if not service.model and importlib.util.find_spec(service.module) is None:
        return _fail(name, f"{service.module} is not installed with this sdvisc")
    try:
        cfg = _validate(service, path)
    except ConfigError as exc:
        return _fail(name, str(exc))
    out = getattr(cfg, "out_dir", None) or getattr(cfg, "state_dir", None)
    log = Path(args.log) if args.log else Path(out) / log_name(name, cfg) if out else None
    command_socket = getattr(cfg, "command_socket", None)  # (the OWFCC's)
    try:
        for where in {Path(out) if out else None, log.parent if log else None,
                      Path(command_socket).parent if command_socket else None} - {None}:
            where.mkdir(parents=True, exist_ok=True)
        log_fd = os.open(log, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644) if log else None
    except OSError as exc:
        return _fail(name, f"cannot prepare {exc.filename}: {exc.strerror}")
    argv = [sys.executable, "-m", service.module, "--config", str(path)]
    if name == "sdn-app":
        argv += ["--ofp-port", str(args.ofp_port), "--listen-host", args.listen_host]
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    env.setdefault("OPENBLAS_NUM_THREADS", "1")  # one BLAS thread per service, as in a run (scenarios/processes.py)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p)
    if log_fd is not None:
        os.write(log_fd, f"sdvisc {name}: {time.strftime('%Y-%m-%d %H:%M:%S')} pid {os.getpid()}: "
                         f"{' '.join(argv)}\n".encode())
    return become(argv, env, log_fd)


def become(argv: list[str], env: dict, log_fd: int | None) -> int:
    """Stdout and stderr to ``log_fd`` (if any), then ``os.execve`` of ``argv`` (a seam for the tests)."""
    if log_fd is not None:
        sys.stdout.flush()
        sys.stderr.flush()
        os.dup2(log_fd, 1)
        os.dup2(log_fd, 2)
        os.close(log_fd)
    os.execve(argv[0], argv, env)
    return 0  # (not reached)


def owfcc_send(args) -> int:
    """Send each command (one JSON object) to the OWFCC's command socket; print its answers."""
    lines = []
    for text in args.commands:
        try:
            command = json.loads(text)
        except json.JSONDecodeError as exc:
            return _fail("owfcc-send", f"not JSON: {text!r}: {exc}")
        if not isinstance(command, dict):
            return _fail("owfcc-send", f"a command is a JSON object, not {text!r}")
        lines.append(json.dumps(command))
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as sock:
        sock.bind("")  # an (abstract) address of our own, so the OWFCC can answer
        sock.settimeout(args.timeout)
        try:
            sock.sendto(("\n".join(lines) + "\n").encode(), args.socket)
            answer = sock.recv(65536).decode()
        except TimeoutError:
            return _fail("owfcc-send", f"no answer from the OWFCC on {args.socket} within {args.timeout:g} s")
        except OSError as exc:
            return _fail("owfcc-send", f"cannot reach the OWFCC on {args.socket}: {exc.strerror or exc}")
    print(answer, end="")
    return 0 if all("req_id" in json.loads(line) for line in answer.splitlines() if line.strip()) else 1
