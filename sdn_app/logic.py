"""The SDN application's decisions, as pure code: packets and switch events in, actions out.

Nothing here touches a socket or a switch and nothing reads the wall clock: every entry point
takes ``now`` (seconds) and returns a list of :mod:`sdn_app.flows` actions. The os-ken shim in
:mod:`sdn_app.app` only translates.

:class:`Controller` wires one module per concern around the shared :class:`~sdn_app.state.SdnState`
(paper Section III, plus the testbed's extensions):

* :mod:`sdn_app.requests` — ``ViSC_WT_i``, ``visc_off``, parameter changes from the OWFCC;
* :mod:`sdn_app.routing` — paths and their flows (make before break), each path's flows shaped by
  the managers enabled for its turbine (:mod:`sdn_app.managers`: ingress guard, 1+1 duplication,
  mirroring to the backup SDC, fast-failover protection; routes by :mod:`sdn_app.path_policies`);
* :mod:`sdn_app.recovery` — ``DR_i = ViSC_WT_i ∧ ¬AK_i`` after the hold (:mod:`sdn_app.dr`):
  the managers' ``on_dr`` (reroute) and ``on_link`` hooks; partitions reported once and healed;
* :mod:`sdn_app.sdc_guard` — SDC liveness (a detector, :mod:`sdn_app.liveness`) and failover;
* here: dispatch of packet-ins and of the intake socket's datagrams (strict decoding, access
  control, every drop counted by reason),
  port status (links, plug-and-play on turbine ports), switch connections, the timer and AK.
"""

from __future__ import annotations

from sdn_app import flows as fl
from sdn_app import udp_frame
from sdn_app.managers import enabled_managers
from sdn_app.messages import Messenger
from sdn_app.recovery import Recovery
from sdn_app.requests import Requests
from sdn_app.routing import Routing
from sdn_app.sdc_guard import SdcGuard
from sdn_app.state import SdnState
from sdvisc import wire
from sdvisc.config import AppConfig


class Controller:
    """Pure SDN application state machine (see module docstring)."""

    def __init__(self, config: AppConfig, now: float = 0.0) -> None:
        self.state = SdnState(config)
        self.messenger = Messenger(self.state)
        turbines = {n for n, h in config.topology.hosts.items() if h.role == "turbine"}
        self.manager_selection = config.manager_selection()
        self.managers = enabled_managers(self.manager_selection, turbines)
        self.routing = Routing(self.state, self.messenger, is_dead=lambda sdc: sdc in self.guard.dead,
                               managers=self.managers)
        self.guard = SdcGuard(self.state, self.routing, self.messenger)
        self.recovery = Recovery(self.state, self.routing, self.messenger)
        self.requests = Requests(self.state, self.routing, self.messenger, self.recovery)
        self.connected: set[int] = set()
        self._held_dr: set[tuple[str, float]] = set()  # (turbine, loss start): DRs that waited for an SDC verdict
        self.wire_stats = wire.DecodeStats()
        self._handlers = {
            wire.MsgType.REQUEST: self.requests.on_request,
            wire.MsgType.AK: self._on_ak,
            wire.MsgType.REPLY: self._on_reply,
            wire.MsgType.HEARTBEAT: self.guard.on_heartbeat,
        }
        # the intake socket's senders by IP: (MAC, OpenFlow attachment), as the switches' intake flows check them
        # (the turbines of one GTNET-SKT card share all three: one sender; its AKs name the turbine)
        self._intake_senders = ({h.ip: (h.mac, (self.dpids[h.switch], h.port)) for h in config.topology.hosts.values()
                                 if h.switch in config.topology.intake_ports and h.switch in self.dpids}
                                if config.intake_socket is not None else {})
        self.state.event(now, "app_start", turbines=len(self.tables.t1), switches=len(self.dpids))

    # ------------------------------------------------------------------ the shared state, read-only views
    config = property(lambda self: self.state.config)
    graph = property(lambda self: self.state.graph)
    dpids = property(lambda self: self.state.dpids)
    port_links = property(lambda self: self.state.port_links)
    tables = property(lambda self: self.state.tables)
    paths = property(lambda self: self.state.paths)
    dr = property(lambda self: self.state.dr)
    counters = property(lambda self: self.state.counters)
    active_sdc = property(lambda self: self.state.active_sdc)
    sdc_dead = property(lambda self: self.guard.dead, doc="SDCs declared dead (and not yet seen alive again)")
    partitioned = property(lambda self: self.recovery.partitioned)

    def take_events(self) -> list[dict]:
        out, self.state.events = self.state.events, []
        return out

    def event(self, now: float, kind: str, **detail) -> None:
        """Record an event of the app's own (e.g. the shim's controller take-over)."""
        self.state.event(now, kind, **detail)

    # ------------------------------------------------------------------ switch events
    def switch_up(self, dpid: int, now: float) -> list:
        """A switch connected: base flows, plus the flows of any active path through it."""
        self.connected.add(dpid)
        self.state.event(now, "switch_up", switch=self.state.switch_by_dpid.get(dpid, hex(dpid)))
        self.counters["switch_connects"] += 1
        return self._count("on_connect", list(fl.base_flows(dpid, self.config.controller_vip)) + self._intake_flows(dpid)
                           + self.routing.flows_on(dpid))

    def _count(self, cause: str, actions: list) -> list:
        """Count the switch messages of one decision by its cause (summary.json ``openflow.by_cause``:
        what a request, a connection, a DR costs, apart from keepalives): ``of:<cause>:<kind>``,
        kind ``flow_mods``, ``packet_outs`` or ``other`` (groups, barriers)."""
        for a in actions:
            kind = ("flow_mods" if isinstance(a, (fl.FlowAdd, fl.FlowDelete)) else
                    "packet_outs" if isinstance(a, fl.PacketOut) else "other")
            self.counters[f"of:{cause}:{kind}"] += 1
        return actions

    def _intake_flows(self, dpid: int) -> list:
        """With an intake socket: the flows that forward this switch's hosts' datagrams to it."""
        switch = self.state.switch_by_dpid.get(dpid)
        intake_port = self.config.topology.intake_ports.get(switch)
        if not self._intake_senders or intake_port is None:
            return []
        senders = [(where[1], mac, ip) for ip, (mac, where) in self._intake_senders.items() if where[0] == dpid]
        return fl.intake_flows(dpid, intake_port, senders, self.config.controller_vip, wire.PORT_CONTROLLER)

    def port_status(self, dpid: int, port: int, up: bool, now: float) -> list:
        """A port changed state: update the link set, T3's second digit, and act (recovery)."""
        st = self.state
        switch = st.switch_by_dpid.get(dpid)
        if switch is None:
            return []
        if (switch, port) not in st.port_links:
            return self._turbine_port(switch, port, up, now)
        key = st.link_change(switch, port, up)
        if key is None:
            return []
        st.event(now, "link_up" if up else "link_down", link=sorted(key), switch=switch, port=port)
        return self.recovery.on_link(key, up, now)

    def _turbine_port(self, switch: str, port: int, up: bool, now: float) -> list:
        """A turbine's own access port changed: plug-and-play in T1 (rows removed on unplug and
        restored from the topology on plug); a turbine unplugged while in ViSC loses its path. A
        card serving several turbines from that port takes all of them along."""
        st = self.state
        actions: list = []
        for name in st.turbines_at(switch, port):
            if not up and name in st.tables.t1:
                actions += self.routing.remove(name)
                st.dr.stop(name)
                self.recovery.forget(name)
                st.tables.unplug(name)
                st.event(now, "turbine_unplugged", wt=name, switch=switch, port=port)
            elif up and name not in st.tables.t1:
                st.plug(name)
                st.event(now, "turbine_plugged", wt=name, switch=switch, port=port)
        return actions

    # ------------------------------------------------------------------ the timer
    def barrier_reply(self, dpid: int, tag: str, now: float) -> list:
        """A switch acknowledged a path's flows (the reply to a :class:`sdn_app.flows.Barrier`):
        once every switch of it has, the turbine's DR hold is armed from then."""
        name = self.routing.acknowledged(dpid, tag, now)
        if name is not None:
            self.state.dr.path_ready(name, now)
            self.state.counters["paths_acknowledged"] += 1
            active = self.state.paths[name]
            self.state.event(now, "path_ready", wt=name, version=active.reroutes,
                             after_ms=round((now - active.installed_at) * 1e3, 3))
        return []

    def tick(self, now: float) -> list:
        """Timer entry point: SDC liveness and confirmed DR events. Sends nothing in steady state.
        Also run on every AK = 0 (a turbine's report that its loss lasted the hold acts at once)."""
        actions = self.guard.check(now)
        stalled, resumed = self.guard.stalled(now), self.guard.t_resumed
        # a turbine whose SDC is dead is failed over, not rerouted; one with no path waits for the
        # topology to change; one whose SDC's heartbeats are overdue as well waits for the SDC's verdict
        in_visc = [n for n, p in self.paths.items() if p.sdc not in self.sdc_dead and n not in self.partitioned
                   and not self._awaiting_sdc_verdict(n, p.sdc, now, stalled, resumed)]
        due = self.dr.due(in_visc, now, stalled=stalled, resumed=resumed)
        return actions + self.recovery.on_dr(due, now)

    def next_decision_at(self, now: float) -> float:
        """A time before which :meth:`tick` decides nothing, unless a packet arrives first (the
        shim's timer may sleep until then): ``now`` while anything is in progress (a turbine's
        loss, a path awaiting its acknowledgements, a suspected SDC, the controller's own stall),
        else the earliest moment an AK silence or an SDC's heartbeat silence can make a decision."""
        if self.guard.suspects or self.guard.stalled(now):
            return now
        return min(self.dr.earliest_due(self.paths, now), self.guard.liveness.earliest_silent())

    def _awaiting_sdc_verdict(self, name: str, sdc: str, now: float, stalled: bool, resumed: float) -> bool:
        """The turbine has lost its control packets while its SDC's heartbeats are overdue too
        (suspected, not yet declared dead). Heartbeats never cross the turbine's path, so the SDC,
        not the path, is the likelier cause, and a reroute to it would cure nothing (seen at time
        scale 1: 5 of 20 SDC kills rerouted first and failed over 100–190 ms after the kill). The
        DR waits for the verdict — a heartbeat (the SDC lives: the DR goes ahead) or its death
        (failover) — at most ``sdc_dead_s`` beyond the turbine's hold. Only where a failover can
        follow, and only while this SDC is silent a heartbeat period longer than every other one: a
        stall of the switches delays every heartbeat alike (seen when a failed link comes back and
        Open vSwitch revalidates; under load at a kill the backup's heartbeats are late too, so
        "every SDC overdue" cannot tell the two apart)."""
        live = self.guard.liveness
        known = live.known()
        if not self.config.failover or len(known) < 2 or not live.suspected(sdc, now, resumed):
            return False
        others = min(live.silence(other, now, resumed) for other in known if other != sdc)
        if live.silence(sdc, now, resumed) < others + live.period_s:
            return False
        since = self.dr.loss_since(name, now, stalled=stalled, resumed=resumed)
        if since is None or now >= since + self.dr.hold_of(name) + self.config.sdc_dead_s:
            return False
        if now >= since + self.dr.hold_of(name) and (name, since) not in self._held_dr:
            self._held_dr.add((name, since))
            self.counters["dr_awaiting_sdc"] += 1
            self.state.event(now, "dr_awaiting_sdc", wt=name, sdc=sdc, t_loss=since,
                             silence_ms=round(live.silence(sdc, now, resumed) * 1e3, 1))
        return True

    # ------------------------------------------------------------------ packets
    def packet_in(self, dpid: int, in_port: int, data: bytes, now: float) -> list:
        """A packet reached the controller (table miss or the virtual controller IP)."""
        counters = self.counters
        counters["packet_in"] += 1
        try:
            frame = udp_frame.parse(data)
        except udp_frame.Unparsable:
            counters["drop_unparsable"] += 1
            return []
        if frame is None:
            counters["drop_not_udp"] += 1
            return []
        if frame.ip_dst != self.config.controller_vip or frame.dst_port != wire.PORT_CONTROLLER:
            counters["drop_no_flow"] += 1
            counters[f"drop_no_flow:{frame.ip_src}->{frame.ip_dst}"] += 1
            return []
        return self._dispatch(frame.payload, frame.ip_src, frame.eth_src, now, (dpid, in_port))

    def delivered(self, datagrams: list[tuple[str, bytes]], now: float) -> list:
        """Datagrams ``(source IP, payload)`` that reached the controller's intake socket in one
        wake-up. The switch that forwarded each one matched its sender's port, MAC and IP
        (:func:`sdn_app.flows.intake_flows`), so it comes from the registered host of that IP, at
        that host's port; a source without such a flow is counted and dropped."""
        actions: list = []
        senders, counters = self._intake_senders, self.counters
        for src_ip, payload in datagrams:
            counters["intake_rx"] += 1
            sender = senders.get(src_ip)
            if sender is None:
                counters["drop_intake_unknown_source"] += 1
                continue
            actions += self._dispatch(payload, src_ip, sender[0], now, sender[1])
        return actions

    def _dispatch(self, payload: bytes, src_ip: str, src_mac: str, now: float, where: tuple[int, int]) -> list:
        """One datagram for the controller, from a packet-in or the intake socket: strict decoding,
        its handler, every drop counted."""
        counters = self.counters
        msg = self.wire_stats.decode(payload, header=self.config.header)
        if msg is None:
            counters["drop_malformed"] += 1
            return []
        handler = self._handlers.get(msg.type)
        if handler is None:
            counters["drop_unexpected_type"] += 1
            return []
        self.guard.note_arrival(now)
        try:
            if msg.type == wire.MsgType.REQUEST:
                self.counters["of:request:requests"] += 1
                return self._count("request", handler(msg, src_ip, src_mac, now, where))
            return handler(msg, src_ip, src_mac, now, where)
        except (ValueError, KeyError, TypeError) as exc:  # one bad message never stops the app
            counters["drop_bad_value"] += 1
            self.state.event(now, "drop_bad_value", msg_type=msg.type.name, error=str(exc)[:200])
            return []

    def _on_ak(self, msg: wire.Message, src_ip: str, src_mac: str, now: float, where=None) -> list:
        st = self.state
        row = st.tables.lookup(wire.turbine_name(msg["wt"])) if wire.is_turbine_id(msg["wt"]) else None
        if row is None or row.ip != src_ip or row.mac != src_mac:
            st.counters["drop_ak_unregistered"] += 1
            return []
        name = row.name
        if st.wrong_ingress(name, where):
            st.counters["drop_ak_wrong_port"] += 1
            return []
        if name not in st.paths:
            st.counters["ak_not_in_visc"] += 1
            return []
        sent = msg.header.time if msg.header is not None else None
        accepted = st.dr.on_ak(name, msg["seq"], msg["ak"], msg["ctrl_rx"], msg["ctrl_age_ms"] / 1e3, now, sent=sent)
        track = st.dr.track(name)
        conflict = track.streams.take_conflict()
        if conflict is not None:  # two live AK streams for one turbine: one is forged (sdn_app.ak_streams)
            st.counters["ak_conflict"] += 1
            st.event(now, "ak_conflict", wt=name, **conflict)
        if not accepted:
            st.counters["ak_duplicate" if track.verdict == "stale" else "drop_ak_other_stream"] += 1
            return []
        st.counters["ak_rx"] += 1
        st.tables.set_comm(name, comm_on=bool(msg["ak"]))
        if not msg["ak"]:  # the report that confirms a DR acts at once, not at the next tick
            return self.tick(now)
        return []

    def _on_reply(self, msg: wire.Message, src_ip: str, src_mac: str, now: float, where=None) -> list:
        st = self.state
        if self.guard.sdc_by_addr.get((src_ip, src_mac)) is None or not wire.is_turbine_id(msg["wt"]):
            st.counters["drop_reply_unexpected"] += 1
            return []
        st.counters["sdc_replies"] += 1
        st.event(now, "sdc_reply", src=src_ip, wt=wire.turbine_name(msg["wt"]),
                 cmd=wire.Command(msg["cmd"]).name, status=wire.Status(msg["status"]).name)
        return []

    # ------------------------------------------------------------------ introspection
    def snapshot(self) -> dict:
        """Tables, active paths, link state and counters as JSON-ready data."""
        st = self.state
        return {
            **st.tables.as_dict(),
            "paths": {n: {"sdc": p.sdc, "path": p.path, "installed_at": p.installed_at, "reroutes": p.reroutes,
                          "second_leg": p.second_leg}
                      for n, p in st.paths.items()},
            "down_links": sorted(sorted(k) for k in st.down_links),
            "active_sdc": st.active_sdc,
            "dead_sdcs": sorted(self.sdc_dead),
            "suspected_sdcs": sorted(self.guard.suspects),
            "partitioned": sorted(self.partitioned),
            "managers": {n: None if t is None else sorted(t) for n, t in self.manager_selection.items()},
            "path_policy": self.config.path_policy,
            "connected": sorted(self.connected),
            "acks": {n: {"ak": t.ak, "ctrl_rx": t.ctrl_rx, "dr_confirmed": t.confirmed}
                     for n, t in st.dr.tracks.items()},
        }
