"""The SDN application's decisions, as pure code: packets and switch events in, actions out.

Nothing here touches a socket or a switch and nothing reads the wall clock: every entry point
takes ``now`` (seconds) and returns a list of :mod:`sdn_app.flows` actions. The os-ken shim in
:mod:`sdn_app.app` only translates.

Implemented here: T1–T3 upkeep, the ``ViSC_WT_i`` request (look T1 up, check T2 and T3, choose a
path, install flows both ways, command SDC and turbine, answer the OWFCC), ``visc_off``, parameter
changes forwarded to the SDC, AK bookkeeping, port status → link state, and counting of every
packet the app saw and why it dropped it.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

from os_ken.lib.packet import ethernet, ipv4, packet, udp

from sdn_app import flows as fl
from sdn_app.config import AppConfig
from sdn_app.paths import build_graph, choose_path, hops, link_key, path_links
from sdn_app.tables import Tables, TurbineAddress
from sdvisc import wire


@dataclass
class ActivePath:
    """A turbine's installed path to its SDC."""

    wt: str
    sdc: str
    path: list[str]
    installed_at: float
    cookie: int
    dpids: list[int] = field(default_factory=list)


@dataclass
class AckState:
    """Last AK seen from a turbine."""

    ak: int = 0
    t_last: float = float("-inf")
    ctrl_rx: int = 0
    seq: int = -1


class Controller:
    """Pure SDN application state machine (see module docstring)."""

    def __init__(self, config: AppConfig, now: float = 0.0) -> None:
        self.config = config
        self.graph = build_graph(config.topology)
        self.dpids = {n: s.dpid for n, s in config.topology.switches.items() if s.openflow}
        self.switch_by_dpid = {d: n for n, d in self.dpids.items()}
        self.tables = Tables()
        self.down_links: set[frozenset] = set()
        self.port_links: dict[tuple[str, int], frozenset] = {}
        for link in config.topology.links:
            key = link_key(link.a, link.b)
            self.port_links[(link.a, link.a_port)] = key
            self.port_links[(link.b, link.b_port)] = key
        self.paths: dict[str, ActivePath] = {}
        self.acks: dict[str, AckState] = {}
        self.active_sdc = config.primary_sdc
        self.connected: set[int] = set()
        self.counters: Counter = Counter()
        self.events: list[dict] = []
        self.wire_stats = wire.DecodeStats()
        self.request_seq = 0
        for name, host in config.topology.hosts.items():
            if host.role != "turbine":
                continue
            self.tables.plug(
                TurbineAddress(name, host.cluster or 0, host.number or 0, host.ip, host.mac, host.switch, host.port),
                visc_enabled=name not in config.visc_disabled,
            )
        for name in self.tables.t1:
            self._refresh_link_ok(name)
        self._event(now, "app_start", turbines=len(self.tables.t1), switches=len(self.dpids))

    # ------------------------------------------------------------------ helpers
    def _event(self, now: float, kind: str, **detail) -> None:
        self.events.append({"t_wall": now, "type": kind, **detail})

    def take_events(self) -> list[dict]:
        out, self.events = self.events, []
        return out

    def _host(self, name: str):
        return self.config.topology.hosts[name]

    def _path_to(self, src: str, dst: str) -> list[str] | None:
        return choose_path(self.graph, src, dst, down=self.down_links)

    def _refresh_link_ok(self, wt: str) -> None:
        ok = self._path_to(self.active_sdc, wt) is not None
        self.tables.set_comm(wt, link_ok=ok)

    def _egress(self, host: str) -> tuple[int, int] | None:
        """(dpid, port) of the OpenFlow switch port from which a packet-out reaches ``host``."""
        best = None
        for switch in sorted(self.dpids):
            path = self._path_to(switch, host)
            if path is not None and (best is None or len(path) < len(best)):
                best = path
        if best is None:
            return None
        port = self.graph.edges[best[0], best[1]]["ports"][best[0]]
        return self.dpids[best[0]], port

    def _packet_to(self, host: str, dst_port: int, payload: bytes) -> list:
        egress = self._egress(host)
        if egress is None:
            self.counters["packet_out_unreachable"] += 1
            return []
        info = self._host(host)
        pkt = packet.Packet()
        pkt.add_protocol(ethernet.ethernet(dst=info.mac, src=self.config.controller_vmac, ethertype=fl.ETH_TYPE_IPV4))
        pkt.add_protocol(ipv4.ipv4(dst=info.ip, src=self.config.controller_vip, proto=fl.IP_PROTO_UDP, ttl=64))
        pkt.add_protocol(udp.udp(src_port=wire.PORT_CONTROLLER, dst_port=dst_port))
        pkt.add_protocol(payload)
        pkt.serialize()
        self.counters["packet_out"] += 1
        return [fl.PacketOut(egress[0], egress[1], bytes(pkt.data))]

    def _header(self, now: float) -> wire.Header | None:
        if not self.config.header:
            return None
        self.request_seq += 1
        sec = int(now)
        return wire.Header(self.request_seq, sec, int((now - sec) * 1e9))

    def _reply(self, now: float, req_id: int, status: wire.Status, wid: int, cmd: int, detail: int = 0) -> list:
        payload = wire.encode(wire.MsgType.REPLY, {"req_id": req_id, "status": int(status), "wt": wid,
                                                   "cmd": int(cmd), "detail": detail}, header=self._header(now))
        return self._packet_to(self.config.owfcc, wire.PORT_OWFCC, payload)

    def _command(self, now: float, host: str, port: int, cmd: wire.Command, wid: int, params: dict | None = None) -> list:
        values = {"req_id": self.request_seq + 1, "cmd": int(cmd), "wt": wid,
                  "sdc_ip": wire.ip_to_i32(self._host(self.active_sdc).ip),
                  "mask": 0, "h": 0.0, "d": 0.0, "m_q": 0.0, "v_ref": 0.0, "q_ref": 0.0, "supp": 0}
        if params:
            values.update(params)
        return self._packet_to(host, port, wire.encode(wire.MsgType.REQUEST, values, header=self._header(now)))

    # ------------------------------------------------------------------ switch events
    def switch_up(self, dpid: int, now: float) -> list:
        """A switch connected: base flows, plus the flows of any active path through it."""
        self.connected.add(dpid)
        self._event(now, "switch_up", switch=self.switch_by_dpid.get(dpid, hex(dpid)))
        actions: list = list(fl.base_flows(dpid, self.config.controller_vip))
        for active in self.paths.values():
            actions += [f for f in self._flows_for(active) if f.dpid == dpid]
        return actions

    def port_status(self, dpid: int, port: int, up: bool, now: float) -> list:
        """A port changed state: update the link set and T3's second digit."""
        switch = self.switch_by_dpid.get(dpid)
        key = self.port_links.get((switch, port)) if switch else None
        if key is None:
            return []
        was_down = key in self.down_links
        if up and was_down:
            self.down_links.discard(key)
        elif not up and not was_down:
            self.down_links.add(key)
        else:
            return []
        self._event(now, "link_up" if up else "link_down", link=sorted(key), switch=switch, port=port)
        for name in self.tables.t1:
            self._refresh_link_ok(name)
        return []

    def tick(self, now: float) -> list:
        """Timer entry point (DR hold timers hook here); nothing periodic is sent to switches."""
        return []

    # ------------------------------------------------------------------ packets
    def packet_in(self, dpid: int, in_port: int, data: bytes, now: float) -> list:
        """A packet reached the controller (table miss or the virtual controller IP)."""
        self.counters["packet_in"] += 1
        try:
            pkt = packet.Packet(data)
        except Exception:  # noqa: BLE001 - os-ken's parser raises many types on garbage
            self.counters["drop_unparsable"] += 1
            return []
        ip = pkt.get_protocol(ipv4.ipv4)
        u = pkt.get_protocol(udp.udp)
        eth = pkt.get_protocol(ethernet.ethernet)
        if ip is None or u is None or eth is None:
            self.counters["drop_not_udp"] += 1
            return []
        if ip.dst != self.config.controller_vip or u.dst_port != wire.PORT_CONTROLLER:
            self.counters["drop_no_flow"] += 1
            self.counters[f"drop_no_flow:{ip.src}->{ip.dst}"] += 1
            return []
        payload = bytes(pkt.protocols[-1]) if isinstance(pkt.protocols[-1], (bytes, bytearray)) else b""
        msg = self.wire_stats.decode(payload, header=self.config.header)
        if msg is None:
            self.counters["drop_malformed"] += 1
            return []
        handler = {
            wire.MsgType.REQUEST: self._on_request,
            wire.MsgType.AK: self._on_ak,
            wire.MsgType.REPLY: self._on_reply,
            wire.MsgType.HEARTBEAT: self._on_heartbeat,
        }.get(msg.type)
        if handler is None:
            self.counters["drop_unexpected_type"] += 1
            return []
        return handler(msg, ip.src, eth.src, now)

    def _on_request(self, msg: wire.Message, src_ip: str, src_mac: str, now: float) -> list:
        owfcc = self._host(self.config.owfcc)
        if src_ip != owfcc.ip or src_mac != owfcc.mac:
            self.counters["drop_request_not_owfcc"] += 1
            return []
        self.counters["requests"] += 1
        cmd, wid, req_id = msg["cmd"], msg["wt"], msg["req_id"]
        name = wire.turbine_name(wid)
        row = self.tables.lookup(name)
        if row is None:
            self._event(now, "request_refused", wt=name, cmd=wire.Command(cmd).name, reason="unknown turbine")
            return self._reply(now, req_id, wire.Status.UNKNOWN_TURBINE, wid, cmd)
        if cmd == wire.Command.VISC_ON:
            return self._visc_on(msg, name, now)
        if cmd == wire.Command.VISC_OFF:
            return self._visc_off(msg, name, now)
        if cmd == wire.Command.SET_PARAMS:
            if not self.tables.in_visc(name):
                return self._reply(now, req_id, wire.Status.REFUSED, wid, cmd, detail=1)
            params = {k: msg[k] for k in ("mask", "h", "d", "m_q", "v_ref", "q_ref", "supp")}
            self._event(now, "set_params", wt=name, **params)
            return (self._command(now, self.active_sdc, wire.PORT_SDC, wire.Command.SET_PARAMS, wid, params)
                    + self._reply(now, req_id, wire.Status.OK, wid, cmd))
        return self._reply(now, req_id, wire.Status.BAD_REQUEST, wid, cmd)

    def _flows_for(self, active: ActivePath) -> list:
        sdc_ip = self._host(active.sdc).ip
        wt_ip = self.tables.t1[active.wt].ip
        return fl.path_flows(hops(self.graph, active.path), self.dpids, sdc_ip, wt_ip, active.cookie)

    def _visc_on(self, msg: wire.Message, name: str, now: float) -> list:
        wid, req_id, cmd = msg["wt"], msg["req_id"], msg["cmd"]
        if not self.tables.visc_enabled(name):
            self._event(now, "request_refused", wt=name, cmd="VISC_ON", reason="ViSC not enabled (T2 x/0)")
            return self._reply(now, req_id, wire.Status.NOT_ENABLED, wid, cmd)
        self._refresh_link_ok(name)
        path = self._path_to(self.active_sdc, name)
        if path is None or not self.tables.comm(name).second:
            self._event(now, "request_refused", wt=name, cmd="VISC_ON", reason="no path (T3 x/0)")
            return self._reply(now, req_id, wire.Status.NO_PATH, wid, cmd)
        actions: list = []
        if name in self.paths:  # already on: re-install (idempotent request)
            actions += self._remove_path(name)
        active = ActivePath(name, self.active_sdc, path, now, fl.turbine_cookie(wid))
        flows = self._flows_for(active)
        active.dpids = sorted({f.dpid for f in flows})
        self.paths[name] = active
        self.tables.set_mode(name, True)
        self.tables.set_comm(name, comm_on=True, link_ok=True)
        self.acks.setdefault(name, AckState())
        self.counters["flow_mods"] += len(flows)
        params = {k: msg[k] for k in ("mask", "h", "d", "m_q", "v_ref", "q_ref", "supp")}
        self._event(now, "visc_on", wt=name, sdc=self.active_sdc, path=path, flows=len(flows))
        actions += flows
        actions += self._command(now, self.active_sdc, wire.PORT_SDC, wire.Command.START_INSTANCE, wid, params)
        actions += self._command(now, name, wire.PORT_TURBINE, wire.Command.STREAM_START, wid)
        actions += self._reply(now, req_id, wire.Status.OK, wid, cmd)
        return actions

    def _remove_path(self, name: str) -> list:
        active = self.paths.pop(name, None)
        if active is None:
            return []
        self.counters["flow_deletes"] += len(active.dpids)
        return [fl.FlowDelete(dpid, active.cookie) for dpid in active.dpids]

    def _visc_off(self, msg: wire.Message, name: str, now: float) -> list:
        wid, req_id, cmd = msg["wt"], msg["req_id"], msg["cmd"]
        if not self.tables.in_visc(name):
            return self._reply(now, req_id, wire.Status.OK, wid, cmd, detail=1)
        actions = self._command(now, name, wire.PORT_TURBINE, wire.Command.STREAM_STOP, wid)
        actions += self._command(now, self.active_sdc, wire.PORT_SDC, wire.Command.STOP_INSTANCE, wid)
        actions += self._remove_path(name)
        self.tables.set_mode(name, False)
        self.tables.set_comm(name, comm_on=False)
        self._event(now, "visc_off", wt=name)
        return actions + self._reply(now, req_id, wire.Status.OK, wid, cmd)

    def _on_ak(self, msg: wire.Message, src_ip: str, src_mac: str, now: float) -> list:
        name = wire.turbine_name(msg["wt"])
        row = self.tables.lookup(name)
        if row is None or row.ip != src_ip or row.mac != src_mac:
            self.counters["drop_ak_unregistered"] += 1
            return []
        state = self.acks.setdefault(name, AckState())
        if msg["seq"] <= state.seq:
            self.counters["ak_duplicate"] += 1
            return []
        self.counters["ak_rx"] += 1
        state.seq, state.ak, state.t_last, state.ctrl_rx = msg["seq"], msg["ak"], now, msg["ctrl_rx"]
        if name in self.paths:
            self.tables.set_comm(name, comm_on=bool(msg["ak"]))
        return []

    def _on_reply(self, msg: wire.Message, src_ip: str, src_mac: str, now: float) -> list:
        self.counters["sdc_replies"] += 1
        self._event(now, "sdc_reply", src=src_ip, wt=wire.turbine_name(msg["wt"]),
                    cmd=wire.Command(msg["cmd"]).name, status=wire.Status(msg["status"]).name)
        return []

    def _on_heartbeat(self, msg: wire.Message, src_ip: str, src_mac: str, now: float) -> list:
        self.counters["heartbeats"] += 1
        return []

    # ------------------------------------------------------------------ introspection
    def snapshot(self) -> dict:
        """Tables, active paths, link state and counters as JSON-ready data."""
        return {
            **self.tables.as_dict(),
            "paths": {n: {"sdc": p.sdc, "path": p.path, "installed_at": p.installed_at} for n, p in self.paths.items()},
            "down_links": sorted(sorted(k) for k in self.down_links),
            "active_sdc": self.active_sdc,
            "connected": sorted(self.connected),
            "acks": {n: {"ak": a.ak, "ctrl_rx": a.ctrl_rx} for n, a in self.acks.items()},
        }


__all__ = ["Controller", "path_links"]
