"""The live view of an interactive session (``sdvisc run --cli --web [PORT]``): one read-only page.

Served by Python's own ``http.server`` (ThreadingHTTPServer, no dependency) on 127.0.0.1 only;
connections from any other address are refused (:meth:`_Server.verify_request`) and requests
naming another host are answered 403 (no DNS rebinding). There are only GET endpoints and none
acts on the testbed: ``/`` (the page), ``/static/…`` (its files, :data:`STATIC`), ``/topology.json``
(switches, hosts, links and a layout) and ``/live`` (server-sent events: a :func:`snapshot` every
:data:`UPDATE_S` wall seconds — scenario time, T1–T3, installed paths, down links, each ViSC
turbine's V, Q, f and control-packet rate — and the events and feedback lines since the last).
The page draws with uPlot (MIT, vendored in ``web_static/``; no CDN, no build step).
"""

from __future__ import annotations

import ipaddress
import json
import threading
import time
from collections import deque
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

STATIC_DIR = Path(__file__).resolve().parent / "web_static"
STATIC = {"index.html": "text/html; charset=utf-8", "live.js": "text/javascript; charset=utf-8",
          "live.css": "text/css; charset=utf-8", "uPlot.iife.min.js": "text/javascript; charset=utf-8",
          "uPlot.min.css": "text/css; charset=utf-8"}
UPDATE_S = 0.1  # wall seconds between two snapshots (the page asks for at least every 200 ms)
HISTORY_POINTS = 3000  # plot points kept for a page that connects later (5 min of wall time)
EVENTS_PER_UPDATE = 200


def layout(desc: dict) -> dict:
    """Nodes (switches and hosts with x, y in 0…1) and links of a topology description
    (:func:`topologies.base.describe`), drawn in layers: services on top, switches by their hop
    distance from the services' switches, turbines below their switch."""
    switches, hosts = desc["switches"], desc["hosts"]
    neighbours: dict[str, set[str]] = {s: set() for s in switches}
    for link in desc["links"]:
        if link["a"] in switches and link["b"] in switches:
            neighbours[link["a"]].add(link["b"])
            neighbours[link["b"]].add(link["a"])
    depth = {h["switch"]: 0 for h in hosts.values() if h["role"] != "turbine" and h["switch"] in switches}
    frontier = sorted(depth) or sorted(switches)[:1]
    depth.update(dict.fromkeys(frontier, 0))
    while frontier:
        nxt = []
        for s in frontier:
            for n in sorted(neighbours[s]):
                if n not in depth:
                    depth[n] = depth[s] + 1
                    nxt.append(n)
        frontier = nxt
    for s in switches:
        depth.setdefault(s, 0)
    rows: dict[int, list[str]] = {}
    for s in sorted(switches, key=lambda s: (depth[s], s)):
        rows.setdefault(depth[s] + 1, []).append(s)
    services = sorted(n for n, h in hosts.items() if h["role"] != "turbine")
    rows[0] = services
    bottom = max(rows) + 1
    turbines = sorted((n for n, h in hosts.items() if h["role"] == "turbine"),
                      key=lambda n: (rows.get(depth.get(hosts[n]["switch"], 0) + 1, []).index(hosts[n]["switch"])
                                     if hosts[n]["switch"] in switches else 0, n))
    rows[bottom] = turbines
    nodes = {}
    n_rows = max(rows) + 1
    for r, names in rows.items():
        for i, name in enumerate(names):
            kind = "switch" if name in switches else hosts[name]["role"]
            nodes[name] = {"x": round((i + 0.5) / len(names), 4), "y": round((r + 0.5) / n_rows, 4), "kind": kind,
                           "openflow": switches[name]["openflow"] if name in switches else None}
    links = [sorted((lk["a"], lk["b"])) for lk in desc["links"]]
    links += [sorted((n, h["switch"])) for n, h in hosts.items()]
    return {"nodes": nodes, "links": sorted(links)}


def snapshot(t: float, status: dict, previous: dict | None, sdn: dict, links_down) -> dict:
    """What the page shows now (``status``: plant_status.json, ``previous``: the one before,
    ``sdn``: the SDN app's state, ``links_down``: the links the run took down)."""
    tables = sdn.get("tables", {})
    turbines = {}
    prev_rows = (previous or {}).get("turbines", {})
    dt = status.get("t_sim", 0.0) - (previous or {}).get("t_sim", 0.0)
    for name, row in status.get("turbines", {}).items():
        if not row.get("streaming"):
            continue
        prev = prev_rows.get(name)
        rate = (row["ctrl_rx"] - prev["ctrl_rx"]) / dt if prev is not None and dt > 0 else None
        turbines[name] = {"v": row.get("v"), "q": row.get("q"), "p": row.get("p"), "f_hz": row.get("f_hz"),
                          "ctrl_per_s": round(rate, 1) if rate is not None else None,
                          "ctrl_delay_ms": row.get("ctrl_delay_ms")}
    down = {tuple(sorted(link)) for link in tables.get("down_links", [])} | {tuple(sorted(lk)) for lk in links_down}
    return {"t": round(t, 3), "t_sim": status.get("t_sim"), "late_steps": status.get("late_steps", 0),
            "T1": tables.get("T1", {}), "T2": tables.get("T2", {}), "T3": tables.get("T3", {}),
            "paths": {n: p.get("path") for n, p in tables.get("paths", {}).items()},
            "active_sdc": tables.get("active_sdc"), "dead_sdcs": tables.get("dead_sdcs", []),
            "down_links": sorted(list(d) for d in down), "turbines": turbines}


def _is_loopback(address: str) -> bool:
    try:
        return ipaddress.ip_address(address.split("%")[0]).is_loopback
    except ValueError:
        return False


class _Server(ThreadingHTTPServer):
    daemon_threads = True
    view: LiveView

    def verify_request(self, request, client_address) -> bool:
        return _is_loopback(client_address[0])  # anything else: the connection is closed unanswered


class _Handler(BaseHTTPRequestHandler):
    server: _Server
    protocol_version = "HTTP/1.1"

    def log_message(self, format, *args):  # noqa: A002 - the base class's name
        pass  # the terminal is the user's prompt

    def _send(self, code: int, body: bytes, content_type: str = "text/plain; charset=utf-8") -> None:
        self.send_response(code)
        self.send_header("Content-Type", content_type)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.send_header("X-Content-Type-Options", "nosniff")
        self.end_headers()
        self.wfile.write(body)

    def _host_ok(self) -> bool:
        host = (self.headers.get("Host") or "").rsplit(":", 1)[0].strip("[]")
        return host in ("127.0.0.1", "localhost", "::1")

    def do_GET(self):  # noqa: N802 - http.server's name
        view = self.server.view
        path = self.path.split("?", 1)[0]
        if not self._host_ok():
            return self._send(403, b"the live view answers only requests for 127.0.0.1 or localhost\n")
        if path == "/":
            path = "/static/index.html"
        if path.startswith("/static/") and path.removeprefix("/static/") in STATIC:
            name = path.removeprefix("/static/")
            return self._send(200, (STATIC_DIR / name).read_bytes(), STATIC[name])
        if path == "/topology.json":
            return self._send(200, json.dumps(view.topology()).encode(), "application/json")
        if path == "/live":
            return self._stream(view)
        return self._send(404, b"not found\n")

    def _stream(self, view: LiveView) -> None:
        self.send_response(200)
        self.send_header("Content-Type", "text/event-stream")
        self.send_header("Cache-Control", "no-store")
        self.send_header("Connection", "close")
        self.end_headers()
        self.close_connection = True
        cursor = {"events": max(0, view.events_count() - EVENTS_PER_UPDATE), "lines": 0}
        try:
            first = True
            while not view.stopping.is_set():
                data = view.update(cursor, history=first)
                first = False
                self.wfile.write(f"data: {json.dumps(data)}\n\n".encode())
                self.wfile.flush()
                if data.get("ended"):
                    break
                time.sleep(UPDATE_S)
        except (BrokenPipeError, ConnectionResetError, OSError):
            pass


class LiveView:
    """The server of one session (see the module docstring)."""

    def __init__(self, run, session, port: int, host: str = "127.0.0.1") -> None:
        self.run = run
        self.session = session
        self.stopping = threading.Event()
        self.server = _Server((host, port), _Handler)
        self.server.view = self
        self.port = self.server.server_address[1]
        self.url = f"http://127.0.0.1:{self.port}/"
        self._thread = threading.Thread(target=self.server.serve_forever, name="sdvisc-web", daemon=True)
        self._collector = threading.Thread(target=self._collect, name="sdvisc-web-collect", daemon=True)
        self._topology = None
        self._last_status: dict = {}
        self.latest: dict = {}
        self.history: deque = deque(maxlen=HISTORY_POINTS)  # plot points of the last HISTORY_POINTS snapshots

    def start(self) -> LiveView:
        self._collector.start()
        self._thread.start()
        return self

    def stop(self) -> None:
        self.stopping.set()
        self.server.shutdown()
        self.server.server_close()

    def _collect(self) -> None:
        """One snapshot every UPDATE_S for every client (one read of the state files), and the
        plot history a page gets when it connects."""
        previous = None
        while not self.stopping.is_set():
            try:
                self.collect_once(previous)
            except Exception as exc:  # noqa: BLE001 - a bad state file read must not freeze the page
                self.latest = dict(self.latest, error=f"{type(exc).__name__}: {exc}")
            previous = self._last_status or previous
            time.sleep(UPDATE_S)

    def collect_once(self, previous: dict | None) -> dict:
        run = self.run
        status = run.plant_status() or {}
        snap = snapshot(self.session.now(), status, previous, run.sdn_state() or {}, run.links_down)
        self._last_status = status
        if snap["turbines"] and (not self.history or snap["t_sim"] != self.history[-1]["t_sim"]):
            self.history.append({"t_sim": snap["t_sim"], "turbines": snap["turbines"]})
        self.latest = snap
        return snap

    def topology(self) -> dict:
        if self._topology is None:
            sc = self.run.scenario
            self._topology = {"scenario": sc.name, "topology": sc.topology.name, **layout(self.run.desc),
                              "timeline_s": sc.duration_s, "time_scale": self.run.clock.time_scale}
        return self._topology

    def events_count(self) -> int:
        return len(self.session.events)

    def update(self, cursor: dict, history: bool = False) -> dict:
        """The latest snapshot for a client; ``cursor``: how many events and feedback lines it
        has had; ``history``: with the plot points so far (a page that just connected)."""
        session = self.session
        data = dict(self.latest or self.collect_once(None))
        if history:
            data["history"] = list(self.history)
        events = session.events
        start = min(cursor["events"], len(events))
        data["events"] = events[start:start + EVENTS_PER_UPDATE]
        cursor["events"] = start + len(data["events"])
        data["lines"] = session.lines[cursor["lines"]:]
        cursor["lines"] += len(data["lines"])
        data["ended"] = session.ended.is_set()
        return data
