"""The SDN application's decisions, as pure code: packets and switch events in, actions out.

Nothing here touches a socket or a switch and nothing reads the wall clock: every entry point
takes ``now`` (seconds) and returns a list of :mod:`sdn_app.flows` actions. The os-ken shim in
:mod:`sdn_app.app` only translates.

What it does (paper Section III, plus the testbed's extensions):

* T1–T3 upkeep (:mod:`sdn_app.tables`) from the topology, requests, port status and AK;
* ``ViSC_WT_i``: look T1 up, check T2 (enabled) and T3 (a link exists), choose a path
  (:mod:`sdn_app.paths`), install flows both ways, command SDC and turbine, answer the OWFCC;
  ``visc_off`` and parameter changes likewise; refusals are answered with a reason;
* ``DR_i = ViSC_WT_i ∧ ¬AK_i`` after the hold (:mod:`sdn_app.dr`): reroute around the failure
  (known down links, else a link-disjoint alternative), optionally also at once on port status;
* SDC failover: a primary without heartbeat for ``sdc_dead_s`` whose turbines also report a loss of
  control packets (AK) is dead; its turbines' flows are
  redirected to the backup with address rewriting (the turbine keeps addressing the same SDC) and
  the backup, which received mirrored measurements, is told to take over;
* access control: requests only from the OWFCC, AK only from T1-registered (IP, MAC) sources;
  everything dropped is counted by reason.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

from os_ken.lib.packet import ethernet, ipv4, packet, udp

from sdn_app import flows as fl
from sdn_app.config import AppConfig
from sdn_app.dr import DrMonitor
from sdn_app.liveness import SdcLiveness
from sdn_app.paths import build_graph, choose_path, hops, link_key, path_links
from sdn_app.protection import protect_direction
from sdn_app.tables import Tables, TurbineAddress
from sdvisc import wire

ETH_TYPE_LEARN = 0x88B5  # IEEE local experimental ethertype: frames that only teach L2 switches
PARAM_KEYS = ("mask", "h", "d", "m_q", "v_ref", "q_ref", "supp")
SETTLE_S = 0.2  # no SDC-death decision this soon after our own flow changes (unless the silence began before them)
CORROBORATE_S = 0.020  # every served turbine's loss must have lasted this long to confirm an SDC death
HEARTBEAT_PERIOD_S = 0.010  # the SDC's nominal heartbeat period (sdc_unit.service.HEARTBEAT_S)
IDLE_SDC_DEAD_FACTOR = 3.0  # an SDC serving no turbine (no corroboration possible): this many sdc_dead_s
STALL_S = 0.015  # no packet-in at all from anyone for this long: our own (or the switches') stall
MAX_STALL_S = 0.5  # ... but a silence this long is no stall any more (nothing is left that talks to us)


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
    params: dict = field(default_factory=dict)  # the ViSC parameters of the request (re-sent to a restarted SDC)


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
        self.dr = DrMonitor(config.dr_hold_s, config.ak_timeout_s)
        self.active_sdc = config.primary_sdc
        self.liveness = SdcLiveness(HEARTBEAT_PERIOD_S, config.sdc_dead_s)
        self.suspects: set[str] = set()  # silent SDCs not (yet) confirmed dead: one event per episode
        self.partitioned: dict[str, float] = {}  # turbines with no path to their SDC, since (t_loss)
        self.t_last_packet_in = float("-inf")
        self.t_resumed = float("-inf")  # end of the last stall: a packet-in after none for STALL_S
        self.connected: set[int] = set()
        self.counters: Counter = Counter()
        self.events: list[dict] = []
        self.wire_stats = wire.DecodeStats()
        self.request_seq = 0
        self.group_ids: dict[int, int] = {}
        self.t_flow_change = float("-inf")
        self._handlers = {
            wire.MsgType.REQUEST: self._on_request,
            wire.MsgType.AK: self._on_ak,
            wire.MsgType.REPLY: self._on_reply,
            wire.MsgType.HEARTBEAT: self._on_heartbeat,
        }
        hosts = config.topology.hosts
        self._sdc_by_addr = {(hosts[n].ip, hosts[n].mac): n for n in (config.primary_sdc, config.backup_sdc)
                             if n in hosts}
        self.port_up: dict[tuple[str, int], bool] = {}
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

    @property
    def sdc_dead(self) -> set[str]:
        """SDCs declared dead (and not yet seen alive again)."""
        return self.liveness.dead

    def _wrong_ingress(self, host: str, where: tuple[int, int] | None) -> bool:
        """True if a packet claiming to come from ``host`` entered the network elsewhere than its
        registered port. Checkable only where that port is an OpenFlow port; behind a plain L2
        switch (the paper topology's turbines) the controller sees the uplink, so a host on the
        same L2 switch can impersonate another one (docs/sdn.md)."""
        info = self.config.topology.hosts.get(host)
        if where is None or info is None or info.switch not in self.dpids:
            return False
        return where != (self.dpids[info.switch], info.port)

    def _host(self, name: str):
        return self.config.topology.hosts[name]

    def _addr(self, name: str) -> dict:
        h = self._host(name)
        return {"ip": h.ip, "mac": h.mac}

    def _path_to(self, src: str, dst: str, avoid=frozenset()) -> list[str] | None:
        return choose_path(self.graph, src, dst, down=self.down_links, avoid=avoid)

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

    def _learn_frames(self, path: list[str], src_host: str) -> list:
        """Teach non-OpenFlow switches on ``path`` where ``src_host`` and the controller's virtual
        address now are (frames with their MACs sent from the OpenFlow switch in front of them), so
        an L2 switch with two uplinks follows a reroute at once instead of after MAC ageing — for
        the SDC's packets and for the turbine's AK to the controller alike."""
        actions = []
        dst_mac = self._host(path[-1]).mac if path[-1] in self.config.topology.hosts else "ff:ff:ff:ff:ff:ff"
        for a, b in zip(path, path[1:]):
            if a in self.dpids and b in self.config.topology.switches and b not in self.dpids:
                for src_mac in (self._host(src_host).mac, self.config.controller_vmac):
                    pkt = packet.Packet()
                    pkt.add_protocol(ethernet.ethernet(dst=dst_mac, src=src_mac, ethertype=ETH_TYPE_LEARN))
                    pkt.add_protocol(b"sdvisc-learn".ljust(46, b"\0"))
                    pkt.serialize()
                    self.counters["packet_out"] += 1
                    actions.append(fl.PacketOut(self.dpids[a], self.graph.edges[a, b]["ports"][a], bytes(pkt.data)))
        return actions

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

    def _command(self, now: float, host: str, port: int, cmd: wire.Command, wid: int, params: dict | None = None,
                 sdc: str | None = None) -> list:
        values = {"req_id": self.request_seq + 1, "cmd": int(cmd), "wt": wid,
                  "sdc_ip": wire.ip_to_i32(self._host(sdc or self.config.primary_sdc).ip),
                  "mask": 0, "h": 0.0, "d": 0.0, "m_q": 0.0, "v_ref": 0.0, "q_ref": 0.0, "supp": 0}
        if params:
            values.update(params)
        return self._packet_to(host, port, wire.encode(wire.MsgType.REQUEST, values, header=self._header(now)))

    # ------------------------------------------------------------------ flows of a path
    def _flows_for(self, active: ActivePath) -> list:
        wt_ip = self.tables.t1[active.wt].ip
        if active.sdc == self.config.primary_sdc:
            flows = fl.path_flows(hops(self.graph, active.path), self.dpids, self._host(active.sdc).ip, wt_ip,
                                  active.cookie)
            flows = self._guard_ingress(active, flows)
            return self._protect(active, flows + self._mirror_flows(active, flows))
        # served by a substitute SDC while addressing the primary's address
        return self._guard_ingress(active, fl.substitute_path_flows(
            hops(self.graph, active.path), self.dpids, self._addr(active.sdc), wt_ip,
            self._addr(self.config.primary_sdc), active.cookie))

    def _next_group_id(self, dpid: int) -> int:
        self.group_ids[dpid] = self.group_ids.get(dpid, 0) + 1
        return self.group_ids[dpid]

    def _protect(self, active: ActivePath, flows: list) -> list:
        """With ``fast_failover``: FF groups and detour flows for both directions of the path;
        returns group adds first (flows refer to them), then the flows."""
        if not self.config.fast_failover:
            return flows
        sdc_ip, wt_ip = self._host(active.sdc).ip, self.tables.t1[active.wt].ip
        path = active.path if active.path[0] == active.sdc else list(reversed(active.path))
        groups, detours, out = [], [], list(flows)
        for direction, (src, dst) in ((path, (sdc_ip, wt_ip)), (list(reversed(path)), (wt_ip, sdc_ip))):
            replace, g, d = protect_direction(self.graph, self.dpids, direction, fl.udp_match(src, dst),
                                              active.cookie, self.down_links, self._next_group_id)
            groups += g
            detours += d
            by_dpid = {self.dpids[x]: acts for x, acts in replace.items()}
            for k, f in enumerate(out):
                if (f.dpid in by_dpid and f.match.get("ipv4_src") == src and f.match.get("ipv4_dst") == dst
                        and len(f.actions) == 1 and isinstance(f.actions[0], fl.Output)):
                    out[k] = fl.FlowAdd(f.dpid, f.priority, f.match, by_dpid[f.dpid], f.cookie)
        active.groups = [(g.dpid, g.group_id) for g in groups]
        self.counters["ff_groups"] += len(groups)
        return groups + out + detours

    def _guard_ingress(self, active: ActivePath, flows: list) -> list:
        """Access control: on the OpenFlow switch where the turbine's packets enter, its upstream
        flow also matches the T1-registered MAC and ingress port, so a host spoofing its IP (or
        any other host) reaches only the table miss, where it is counted and dropped."""
        path = active.path if active.path[-1] == active.wt else list(reversed(active.path))
        of_hops = hops(self.graph, path)
        if not of_hops:
            return flows
        ingress, _, toward_wt = of_hops[-1]
        row = self.tables.t1[active.wt]
        guarded = []
        for f in flows:
            if f.dpid == self.dpids[ingress] and f.match.get("ipv4_src") == row.ip:
                f = fl.FlowAdd(f.dpid, f.priority, {**f.match, "in_port": toward_wt, "eth_src": row.mac},
                               f.actions, f.cookie)
            guarded.append(f)
        return guarded

    def _mirror_flows(self, active: ActivePath, flows: list) -> list:
        backup = self.config.backup_sdc
        if not (backup and self.config.failover and self.config.mirror_to_backup) or backup in self.sdc_dead:
            return []
        primary_ip = self._host(active.sdc).ip
        first_switch = active.path[1]
        to_backup = self._path_to(first_switch, backup)
        if to_backup is None or first_switch not in self.dpids:
            return []
        upstream = next((f for f in flows if f.dpid == self.dpids[first_switch] and f.match["ipv4_dst"] == primary_ip),
                        None)
        if upstream is None:
            return []
        hop_list = [(to_backup[0], 0, self.graph.edges[to_backup[0], to_backup[1]]["ports"][to_backup[0]])]
        hop_list += hops(self.graph, to_backup)
        mirrored = fl.mirror_flows(hop_list, self.dpids, upstream, self._addr(backup), self.tables.t1[active.wt].ip,
                                   active.cookie)
        # the mirror flow replaces the plain upstream flow on the first switch (same match, same priority)
        flows.remove(upstream)
        return mirrored

    def _install(self, name: str, sdc: str, path: list[str], wid: int, now: float) -> list:
        """Install (or move) a turbine's path: new flows first, under a new cookie version, then
        the old version's flows are deleted (make before break; on switches both paths share, the
        new flow overwrites the old one in place)."""
        old = self.paths.get(name)
        version = old.reroutes + 1 if old is not None else 0
        active = ActivePath(name, sdc, path, now, fl.turbine_cookie(wid, version))
        flows = self._flows_for(active)
        active.installed = flows
        active.dpids = sorted({f.dpid for f in flows if isinstance(f, fl.FlowAdd)})
        active.reroutes = version
        self.paths[name] = active
        self.t_flow_change = now
        self.counters["flow_mods"] += sum(isinstance(f, fl.FlowAdd) for f in flows)
        actions = flows + self._learn_frames(list(reversed(path)) if path[0] == name else path, sdc)
        if old is not None:
            actions += self._delete(old)
        return actions

    def _delete(self, active: ActivePath) -> list:
        self.counters["flow_deletes"] += len(active.dpids)
        return ([fl.FlowDelete(dpid, active.cookie) for dpid in active.dpids]
                + [fl.GroupDelete(dpid, gid) for dpid, gid in active.groups])

    def _remove_path(self, name: str) -> list:
        active = self.paths.pop(name, None)
        if active is None:
            return []
        return self._delete(active)

    # ------------------------------------------------------------------ switch events
    def switch_up(self, dpid: int, now: float) -> list:
        """A switch connected: base flows, plus the flows of any active path through it."""
        self.connected.add(dpid)
        self._event(now, "switch_up", switch=self.switch_by_dpid.get(dpid, hex(dpid)))
        actions: list = list(fl.base_flows(dpid, self.config.controller_vip))
        for active in self.paths.values():
            actions += [f for f in active.installed if f.dpid == dpid]
        return actions

    def port_status(self, dpid: int, port: int, up: bool, now: float) -> list:
        """A port changed state: update the link set, T3's second digit, and optionally reroute."""
        switch = self.switch_by_dpid.get(dpid)
        key = self.port_links.get((switch, port)) if switch else None
        if key is None:
            return self._turbine_port(switch, port, up, now)
        self.port_up[(switch, port)] = up
        ends = [(n, p) for (n, p), k in self.port_links.items() if k == key and n in self.dpids]
        link_up = all(self.port_up.get(end, True) for end in ends)  # up only when every visible end is
        was_down = key in self.down_links
        if link_up and was_down:
            self.down_links.discard(key)
        elif not link_up and not was_down:
            self.down_links.add(key)
        else:
            return []
        up = link_up
        self._event(now, "link_up" if up else "link_down", link=sorted(key), switch=switch, port=port)
        for name in self.tables.t1:
            self._refresh_link_ok(name)
        actions: list = []
        if not up and self.config.fast_failover:
            actions += self._relearn_behind_l2(key, now)
        if not up and self.config.reroute_on_port_status:
            for name, active in list(self.paths.items()):
                if key in path_links(active.path) and name not in self.partitioned:
                    actions += self._reroute(name, "port_status", now, t_loss=None)
        if up:
            actions += self._heal(now)
        return actions

    def _turbine_port(self, switch: str | None, port: int, up: bool, now: float) -> list:
        """A turbine's own access port changed: plug-and-play in T1 (rows removed on unplug and
        restored from the topology on plug); a turbine unplugged while in ViSC loses its path."""
        name = next((n for n, h in self.config.topology.hosts.items()
                     if h.role == "turbine" and h.switch == switch and h.port == port), None)
        if name is None:
            return []
        actions: list = []
        if not up and name in self.tables.t1:
            actions += self._remove_path(name)
            self.dr.stop(name)
            self.tables.unplug(name)
            self._event(now, "turbine_unplugged", wt=name, switch=switch, port=port)
        elif up and name not in self.tables.t1:
            h = self._host(name)
            self.tables.plug(TurbineAddress(name, h.cluster or 0, h.number or 0, h.ip, h.mac, h.switch, h.port),
                             visc_enabled=name not in self.config.visc_disabled)
            self._refresh_link_ok(name)
            self._event(now, "turbine_plugged", wt=name, switch=switch, port=port)
        return actions

    def _relearn_behind_l2(self, key: frozenset, now: float) -> list:
        """Fast failover cannot teach a non-OpenFlow switch that the SDC is now behind another
        uplink (it keeps sending the turbine's packets into the dead one, and without those packets
        no answer comes back to teach it). When such an uplink of an active path goes down, send a
        learning frame with the SDC's MAC in through every other live uplink: the switch moves the
        SDC there, and the entry detours carry the turbine's packets on."""
        l2 = next((n for n in key if n not in self.dpids and n in self.config.topology.switches), None)
        if l2 is None:
            return []
        actions: list = []
        for name, active in self.paths.items():
            if key not in path_links(active.path):
                continue
            for z in sorted(self.graph.neighbors(l2)):
                if z not in self.dpids or link_key(l2, z) in self.down_links:
                    continue
                actions += self._learn_frames([z, l2, name], active.sdc)
            self._event(now, "ff_relearn", wt=name, l2=l2, link=sorted(key))
        return actions

    def tick(self, now: float) -> list:
        """Timer entry point: SDC liveness and confirmed DR events. Sends nothing in steady state."""
        actions = self._check_sdcs(now)
        # a turbine whose SDC is dead is failed over, not rerouted; one with no path waits for the
        # topology to change. A merely *suspected* SDC never holds a DR back: the DR stands on the
        # turbine's own reports, and an SDC death is decided on its own evidence.
        in_visc = [n for n, p in self.paths.items() if p.sdc not in self.sdc_dead and n not in self.partitioned]
        stalled = self._stalled(now)
        for name, t_loss in self.dr.due(in_visc, now, stalled=stalled, resumed=self.t_resumed):
            if self.config.dynamic_routing:
                actions += self._reroute(name, "dr", now, t_loss=t_loss)
            else:
                self.tables.set_comm(name, comm_on=False)
                self._event(now, "dr_not_acted", wt=name, t_loss=t_loss, reason="dynamic routing off")
        return actions

    # ------------------------------------------------------------------ rerouting
    def _reroute(self, name: str, cause: str, now: float, t_loss: float | None) -> list:
        active = self.paths[name]
        current = set(path_links(active.path))
        known_bad = current & self.down_links
        host_links = {link_key(active.path[0], active.path[1]), link_key(active.path[-2], active.path[-1])}
        avoid = frozenset() if known_bad else frozenset(current - host_links)
        new_path = self._path_to(active.sdc, name, avoid=avoid)
        if new_path is None and avoid:
            candidate = self._path_to(active.sdc, name)
            new_path = candidate if candidate != active.path else None
        self.dr.start(name, now)
        if new_path is None:
            return self._no_path(name, cause, now, t_loss)
        wid = wire.turbine_id(self.tables.t1[name].cluster, self.tables.t1[name].number)
        actions = self._install(name, active.sdc, new_path, wid, now)
        self.tables.set_comm(name, link_ok=True)
        self.counters[f"reroute_{cause}"] += 1
        self._event(now, cause, wt=name, t_loss=t_loss, t_detect=now, old_path=active.path, new_path=new_path,
                    avoided="known down links" if known_bad else "current path (link-disjoint)")
        return actions

    # ------------------------------------------------------------------ partitions
    def _no_path(self, name: str, cause: str, now: float, t_loss: float | None) -> list:
        """No path to the turbine's SDC: reported once, T3 x/0; the turbine falls back on its own
        (as without DR) and nothing is retried until the topology changes (:meth:`_heal`)."""
        if name not in self.partitioned:
            self.partitioned[name] = t_loss if t_loss is not None else now
            self.tables.set_comm(name, comm_on=False, link_ok=False)
            self.counters["no_path"] += 1
            self._event(now, "no_path", wt=name, cause=cause, t_loss=t_loss, t_detect=now,
                        down_links=sorted(sorted(k) for k in self.down_links))
        return []

    def _heal(self, now: float) -> list:
        """A link came up: give every partitioned turbine a path if one exists now."""
        actions: list = []
        for name, t_loss in sorted(self.partitioned.items()):
            active = self.paths.get(name)
            if active is None or name not in self.tables.t1:
                self.partitioned.pop(name)
                continue
            path = self._path_to(active.sdc, name)
            if path is None:
                continue
            self.partitioned.pop(name)
            wid = wire.turbine_id(self.tables.t1[name].cluster, self.tables.t1[name].number)
            actions += self._install(name, active.sdc, path, wid, now)
            self.tables.set_comm(name, link_ok=True)
            self.dr.start(name, now)
            self.counters["path_restored"] += 1
            self._event(now, "path_restored", wt=name, t_loss=t_loss, t_detect=now, new_path=path)
            actions += self._reengage(name, active.sdc, now)
        return actions

    def _reengage(self, name: str, sdc: str, now: float) -> list:
        """After a long interruption (partition healed, SDC restarted) the turbine has fallen back to
        its own control and the SDC's instance is stale or gone: start the instance afresh (bumpless,
        from the turbine's present operating point) and the turbine's remote mode again."""
        row = self.tables.t1[name]
        wid = wire.turbine_id(row.cluster, row.number)
        params = self.paths[name].params if name in self.paths else {}
        return (self._command(now, sdc, wire.PORT_SDC, wire.Command.START_INSTANCE, wid, params, sdc=sdc)
                + self._command(now, name, wire.PORT_TURBINE, wire.Command.STREAM_START, wid))

    # ------------------------------------------------------------------ SDC failover
    def _stalled(self, now: float) -> bool:
        """Nothing at all has reached the controller for a while: its own stall or the switches'
        (a silence then says nothing about any one sender)."""
        return STALL_S < now - self.t_last_packet_in < MAX_STALL_S

    def _check_sdcs(self, now: float) -> list:
        """Decide which silent SDCs are dead (:mod:`sdn_app.liveness` plus the turbines' own
        reports as corroboration), and fail over."""
        actions: list = []
        known = self.liveness.known()
        silent = {sdc for sdc in known if self.liveness.silent(sdc, now, self.t_resumed)}
        self.suspects &= silent
        if silent and self._stalled(now):
            self.counters["sdc_check_stalled"] += 1
            return actions
        if len(known) > 1 and silent == set(known):
            # every SDC silent at once: far likelier our own stall (a busy event loop, a switch busy
            # revalidating) than all SDCs dying together; decide nothing until heartbeats are seen
            self.counters["sdc_check_all_stale"] += 1
            return actions
        for sdc in sorted(silent - self.sdc_dead):
            t_last = self.liveness.tracks[sdc].t_last
            if now - self.t_flow_change < SETTLE_S and t_last >= self.t_flow_change:
                # the switches just received flow changes from us; Open vSwitch's userspace datapath
                # delays their packet-ins (heartbeats, AK) for tens of ms while it revalidates
                self.counters["sdc_check_settling"] += 1
                continue
            served = sorted(n for n, p in self.paths.items() if p.sdc == sdc)
            if not self._death_corroborated(sdc, served, now):
                self.counters["sdc_suspect_not_corroborated"] += 1
                if sdc not in self.suspects:
                    self.suspects.add(sdc)
                    self._event(now, "sdc_suspect", sdc=sdc, silence_ms=round((now - t_last) * 1e3, 1),
                                phi=round(self.liveness.phi(sdc, now, self.t_resumed), 1), turbines=served)
                continue
            self.liveness.declare_dead(sdc)
            self.suspects.discard(sdc)
            self._event(now, "sdc_dead", sdc=sdc, t_last_heartbeat=t_last, turbines=served)
            if sdc == self.active_sdc:
                actions += self._failover(sdc, served, now, t_last)
        return actions

    def _death_corroborated(self, sdc: str, served: list[str], now: float) -> bool:
        """A silent SDC is dead when every turbine it serves has itself reported that its control
        packets stopped (AK = 0 with a loss of ``CORROBORATE_S``; a missing AK is no report), or
        has sent no AK at all since the silence began while other packets arrive; one serving no
        turbine, after a longer silence."""
        silence = self.liveness.silence(sdc, now, self.t_resumed)
        if not served:
            return silence >= IDLE_SDC_DEAD_FACTOR * self.config.sdc_dead_s
        return all(self.dr.reported_loss(n) >= CORROBORATE_S
                   or self.dr.loss_since(n, now, resumed=self.t_resumed) is not None
                   and self.dr.tracks[n].t_loss is None for n in served)

    def _failover(self, dead: str, served: list[str], now: float, t_last: float) -> list:
        backup = self.config.backup_sdc
        if (not self.config.failover or backup is None or backup in self.sdc_dead
                or backup not in self.liveness.tracks):
            self._event(now, "failover_unavailable", sdc=dead, turbines=served,
                        reason="failover off" if not self.config.failover else "no live backup SDC")
            return []
        self.active_sdc = backup
        actions: list = []
        for name in served:
            path = self._path_to(backup, name)
            if path is None:
                self._event(now, "failover_no_path", wt=name, sdc=backup)
                continue
            wid = wire.turbine_id(self.tables.t1[name].cluster, self.tables.t1[name].number)
            actions += self._install(name, backup, path, wid, now)
            actions += self._command(now, backup, wire.PORT_SDC, wire.Command.TAKEOVER, wid, sdc=backup)
            self.dr.start(name, now)
        self.counters["sdc_failovers"] += 1
        self._event(now, "sdc_failover", sdc=dead, backup=backup, turbines=served, t_loss=t_last, t_detect=now)
        return actions

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
        handler = self._handlers.get(msg.type)
        if handler is None:
            self.counters["drop_unexpected_type"] += 1
            return []
        if now - self.t_last_packet_in > STALL_S:
            self.t_resumed = now
        self.t_last_packet_in = max(self.t_last_packet_in, now)
        try:
            return handler(msg, ip.src, eth.src, now, (dpid, in_port))
        except (ValueError, KeyError, TypeError) as exc:  # one bad message never stops the app
            self.counters["drop_bad_value"] += 1
            self._event(now, "drop_bad_value", msg_type=msg.type.name, error=str(exc)[:200])
            return []

    def _on_request(self, msg: wire.Message, src_ip: str, src_mac: str, now: float, where=None) -> list:
        owfcc = self._host(self.config.owfcc)
        if src_ip != owfcc.ip or src_mac != owfcc.mac or self._wrong_ingress(self.config.owfcc, where):
            self.counters["drop_request_not_owfcc"] += 1
            return []
        self.counters["requests"] += 1
        cmd, wid, req_id = msg["cmd"], msg["wt"], msg["req_id"]
        if not wire.is_turbine_id(wid):
            self.counters["drop_unknown_turbine"] += 1
            self._event(now, "request_refused", wt=wid, cmd=wire.Command(cmd).name, reason="not a turbine id")
            return self._reply(now, req_id, wire.Status.UNKNOWN_TURBINE, wid, cmd)
        name = wire.turbine_name(wid)
        if self.tables.lookup(name) is None:
            self._event(now, "request_refused", wt=name, cmd=wire.Command(cmd).name, reason="unknown turbine")
            return self._reply(now, req_id, wire.Status.UNKNOWN_TURBINE, wid, cmd)
        if cmd == wire.Command.VISC_ON:
            return self._visc_on(msg, name, now)
        if cmd == wire.Command.VISC_OFF:
            return self._visc_off(msg, name, now)
        if cmd == wire.Command.SET_PARAMS:
            if not self.tables.in_visc(name):
                return self._reply(now, req_id, wire.Status.REFUSED, wid, cmd, detail=1)
            params = {k: msg[k] for k in PARAM_KEYS}
            self._event(now, "set_params", wt=name, **params)
            return (self._command(now, self.paths[name].sdc, wire.PORT_SDC, wire.Command.SET_PARAMS, wid, params)
                    + self._reply(now, req_id, wire.Status.OK, wid, cmd))
        return self._reply(now, req_id, wire.Status.BAD_REQUEST, wid, cmd)

    def _visc_on(self, msg: wire.Message, name: str, now: float) -> list:
        wid, req_id, cmd = msg["wt"], msg["req_id"], msg["cmd"]
        if not self.tables.visc_enabled(name):
            self._event(now, "request_refused", wt=name, cmd="VISC_ON", reason="ViSC not enabled (T2 x/0)")
            return self._reply(now, req_id, wire.Status.NOT_ENABLED, wid, cmd)
        self._refresh_link_ok(name)
        sdc = self.active_sdc
        path = self._path_to(sdc, name)
        if path is None or not self.tables.comm(name).second:
            self._event(now, "request_refused", wt=name, cmd="VISC_ON", reason="no path (T3 x/0)")
            return self._reply(now, req_id, wire.Status.NO_PATH, wid, cmd)
        actions: list = self._remove_path(name)  # an idempotent re-request re-installs
        actions += self._install(name, sdc, path, wid, now)
        self.tables.set_mode(name, True)
        self.tables.set_comm(name, comm_on=True, link_ok=True)
        self.dr.start(name, now, armed=False)
        self.partitioned.pop(name, None)
        params = {k: msg[k] for k in PARAM_KEYS}
        self.paths[name].params = params
        self._event(now, "visc_on", wt=name, sdc=sdc, path=path, flows=self.counters["flow_mods"])
        actions += self._command(now, sdc, wire.PORT_SDC, wire.Command.START_INSTANCE, wid, params)
        actions += self._command(now, name, wire.PORT_TURBINE, wire.Command.STREAM_START, wid)
        actions += self._reply(now, req_id, wire.Status.OK, wid, cmd)
        return actions

    def _visc_off(self, msg: wire.Message, name: str, now: float) -> list:
        wid, req_id, cmd = msg["wt"], msg["req_id"], msg["cmd"]
        if not self.tables.in_visc(name):
            return self._reply(now, req_id, wire.Status.OK, wid, cmd, detail=1)
        sdc = self.paths[name].sdc if name in self.paths else self.active_sdc
        actions = self._command(now, name, wire.PORT_TURBINE, wire.Command.STREAM_STOP, wid)
        actions += self._command(now, sdc, wire.PORT_SDC, wire.Command.STOP_INSTANCE, wid)
        actions += self._remove_path(name)
        self.dr.stop(name)
        self.partitioned.pop(name, None)
        self.tables.set_mode(name, False)
        self.tables.set_comm(name, comm_on=False)
        self._event(now, "visc_off", wt=name)
        return actions + self._reply(now, req_id, wire.Status.OK, wid, cmd)

    def _on_ak(self, msg: wire.Message, src_ip: str, src_mac: str, now: float, where=None) -> list:
        row = self.tables.lookup(wire.turbine_name(msg["wt"])) if wire.is_turbine_id(msg["wt"]) else None
        if row is None or row.ip != src_ip or row.mac != src_mac:
            self.counters["drop_ak_unregistered"] += 1
            return []
        name = row.name
        if self._wrong_ingress(name, where):
            self.counters["drop_ak_wrong_port"] += 1
            return []
        if name not in self.paths:
            self.counters["ak_not_in_visc"] += 1
            return []
        sent = msg.header.time if msg.header is not None else None
        fresh = self.dr.on_ak(name, msg["seq"], msg["ak"], msg["ctrl_rx"], msg["ctrl_age_ms"] / 1e3, now, sent=sent)
        if not fresh:
            self.counters["ak_duplicate"] += 1
            return []
        self.counters["ak_rx"] += 1
        self.tables.set_comm(name, comm_on=bool(msg["ak"]))
        return []

    def _on_reply(self, msg: wire.Message, src_ip: str, src_mac: str, now: float, where=None) -> list:
        if self._sdc_by_addr.get((src_ip, src_mac)) is None or not wire.is_turbine_id(msg["wt"]):
            self.counters["drop_reply_unexpected"] += 1
            return []
        self.counters["sdc_replies"] += 1
        self._event(now, "sdc_reply", src=src_ip, wt=wire.turbine_name(msg["wt"]),
                    cmd=wire.Command(msg["cmd"]).name, status=wire.Status(msg["status"]).name)
        return []

    def _on_heartbeat(self, msg: wire.Message, src_ip: str, src_mac: str, now: float, where=None) -> list:
        sdc = self._sdc_by_addr.get((src_ip, src_mac))
        if sdc is None or self._wrong_ingress(sdc, where):
            self.counters["drop_heartbeat_unknown"] += 1
            return []
        self.counters["heartbeats"] += 1
        actions: list = []
        for change in self.liveness.on_heartbeat(sdc, msg["seq"], now, self.t_resumed):
            if change == "alive":
                self._event(now, "sdc_alive", sdc=sdc)
            elif change == "restarted":  # the process came back without its instances: re-start them
                served = sorted(n for n, p in self.paths.items() if p.sdc == sdc)
                self._event(now, "sdc_restarted", sdc=sdc, turbines=served)
                for name in served:
                    actions += self._reengage(name, sdc, now)
        return actions

    # ------------------------------------------------------------------ introspection
    def snapshot(self) -> dict:
        """Tables, active paths, link state and counters as JSON-ready data."""
        return {
            **self.tables.as_dict(),
            "paths": {n: {"sdc": p.sdc, "path": p.path, "installed_at": p.installed_at, "reroutes": p.reroutes}
                      for n, p in self.paths.items()},
            "down_links": sorted(sorted(k) for k in self.down_links),
            "active_sdc": self.active_sdc,
            "dead_sdcs": sorted(self.sdc_dead),
            "suspected_sdcs": sorted(self.suspects),
            "partitioned": sorted(self.partitioned),
            "connected": sorted(self.connected),
            "acks": {n: {"ak": t.ak, "ctrl_rx": t.ctrl_rx, "dr_confirmed": t.confirmed}
                     for n, t in self.dr.tracks.items()},
        }
