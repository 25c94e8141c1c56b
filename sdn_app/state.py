"""What every part of the SDN application's logic shares: the network as configured and as it
stands (links down, ports), T1–T3, the installed paths, the AK/DR monitor, counters and events.

Pure: nothing here touches a socket or a clock; every call that records something takes ``now``.
The concerns that act on this state each have their own module (FAUCET's valve managers are the
model): :mod:`sdn_app.messages` (packets the app sends), :mod:`sdn_app.routing` (paths, flows),
:mod:`sdn_app.managers` (what is done to each path's flows and on link changes and DRs, per turbine),
:mod:`sdn_app.recovery` (DR, partitions), :mod:`sdn_app.sdc_guard` (SDC liveness
and failover), :mod:`sdn_app.requests` (the OWFCC's requests); :mod:`sdn_app.logic` wires them.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

from sdn_app.dr import DrMonitor
from sdn_app.path_policies import PATH_POLICIES
from sdn_app.paths import build_graph, choose_path, link_key
from sdn_app.tables import Tables, TurbineAddress
from sdvisc import wire
from sdvisc.config import AppConfig


@dataclass
class ActivePath:
    """A turbine's installed path to the SDC serving it."""

    wt: str
    sdc: str
    path: list[str]
    installed_at: float
    cookie: int
    dpids: list[int] = field(default_factory=list)
    reroutes: int = 0
    groups: list[tuple[int, int]] = field(default_factory=list)  # (dpid, group id) of FF groups
    installed: list = field(default_factory=list)  # the group and flow adds, for switch reconnects
    params: dict = field(default_factory=dict)  # the ViSC parameters of the request (re-sent on re-engage)
    unacknowledged: set = field(default_factory=set)  # switches whose barrier reply is still awaited
    ready_at: float | None = None  # when the last switch of the path acknowledged its flows
    protected_without: frozenset = frozenset()  # links down when its FF detours (or second leg) were computed
    second_leg: list[str] | None = None  # with the duplication manager: the leg that carries the copies (A … B)


class SdnState:
    """The shared state (see the module docstring)."""

    def __init__(self, config: AppConfig) -> None:
        if config.path_policy not in PATH_POLICIES:
            raise ValueError(f"sdn.path_policy: unknown {config.path_policy!r}; known: {sorted(PATH_POLICIES)}")
        self.config = config
        self.graph = build_graph(config.topology)
        self.dpids = {n: s.dpid for n, s in config.topology.switches.items() if s.openflow}
        self.switch_by_dpid = {d: n for n, d in self.dpids.items()}
        self.down_links: set[frozenset] = set()
        self.port_up: dict[tuple[str, int], bool] = {}
        self.port_links: dict[tuple[str, int], frozenset] = {}
        for link in config.topology.links:
            key = link_key(link.a, link.b)
            self.port_links[(link.a, link.a_port)] = key
            self.port_links[(link.b, link.b_port)] = key
        self.tables = Tables()
        self.paths: dict[str, ActivePath] = {}
        self.dr = DrMonitor(config.dr_hold_s, config.ak_timeout_s)
        self.active_sdc = config.primary_sdc
        self.counters: Counter = Counter()
        self.events: list[dict] = []
        for name, host in config.topology.hosts.items():
            if host.role == "turbine":
                self.plug(name)

    # ------------------------------------------------------------------ records
    def event(self, now: float, kind: str, **detail) -> None:
        self.events.append({"t_wall": now, "type": kind, **detail})

    # ------------------------------------------------------------------ hosts and turbines
    def host(self, name: str):
        return self.config.topology.hosts[name]

    def addr(self, name: str) -> dict:
        h = self.host(name)
        return {"ip": h.ip, "mac": h.mac}

    def wid(self, name: str) -> int:
        """The wire id of a turbine in T1."""
        row = self.tables.t1[name]
        return wire.turbine_id(row.cluster, row.number)

    def plug(self, name: str) -> None:
        """Put a turbine of the topology into T1 (T2 from the configuration)."""
        h = self.host(name)
        self.tables.plug(TurbineAddress(name, h.cluster or 0, h.number or 0, h.ip, h.mac, h.switch, h.port,
                                        h.udp_port), visc_enabled=name not in self.config.visc_disabled)
        self.refresh_link_ok(name)

    def endpoint(self, name: str) -> tuple[str, int]:
        """A turbine's endpoint in T1: (IP, UDP port). Its path flows match both, so the turbines of
        one GTNET-SKT card (one IP, a port each) have independent paths."""
        row = self.tables.t1[name]
        return row.ip, row.udp_port

    def turbines_at(self, switch: str | None, port: int) -> list[str]:
        """The turbines whose access port is ``switch``:``port`` (several: one card serving them)."""
        return [n for n, h in self.config.topology.hosts.items()
                if h.role == "turbine" and h.switch == switch and h.port == port]

    def wrong_ingress(self, host: str, where: tuple[int, int] | None) -> bool:
        """True if a packet claiming to come from ``host`` entered the network elsewhere than its
        registered port. Checkable only where that port is an OpenFlow port; behind a plain L2
        switch (the paper topology's turbines) the controller sees the uplink, so a host on the
        same L2 switch can impersonate another one (docs/sdn.md)."""
        info = self.config.topology.hosts.get(host)
        if where is None or info is None or info.switch not in self.dpids:
            return False
        return where != (self.dpids[info.switch], info.port)

    # ------------------------------------------------------------------ the network as it stands
    def path_to(self, src: str, dst: str, avoid=frozenset(), nodes=None) -> list[str] | None:
        """The one way to a path: the scenario's path policy (``sdn.path_policy``,
        :mod:`sdn_app.path_policies`) from ``src`` to ``dst`` around the links known down and those
        in ``avoid`` (through ``nodes`` only, if given); None if there is none."""
        return choose_path(self.graph, src, dst, down=self.down_links, avoid=avoid, nodes=nodes,
                           policy=self.config.path_policy)

    def refresh_link_ok(self, wt: str) -> None:
        """T3's second digit: a path exists between the active SDC and the turbine."""
        self.tables.set_comm(wt, link_ok=self.path_to(self.active_sdc, wt) is not None)

    def link_change(self, switch: str, port: int, up: bool) -> frozenset | None:
        """Record a port's state; returns the link it belongs to if that link changed state (a link
        is up only when every end the app can see is up), else None."""
        key = self.port_links.get((switch, port))
        if key is None:
            return None
        self.port_up[(switch, port)] = up
        ends = [(n, p) for (n, p), k in self.port_links.items() if k == key and n in self.dpids]
        link_up = all(self.port_up.get(end, True) for end in ends)
        if link_up == (key not in self.down_links):
            return None
        (self.down_links.discard if link_up else self.down_links.add)(key)
        for name in self.tables.t1:
            self.refresh_link_ok(name)
        return key
