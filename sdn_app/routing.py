"""Paths and their flows: install (make before break), delete, mirror to the backup SDC, guard
the turbine's ingress, protect with fast-failover groups. Pure: each call returns
:mod:`sdn_app.flows` actions."""

from __future__ import annotations

from collections.abc import Callable

from sdn_app import flows as fl
from sdn_app.duplication import duplicate, second_leg
from sdn_app.messages import Messenger
from sdn_app.paths import hops, link_key, path_links
from sdn_app.protection import protect_direction
from sdn_app.state import ActivePath, SdnState


def path_tag(name: str, version: int) -> str:
    """The barrier tag of a turbine's path version (``wt1_1#2``)."""
    return f"{name}#{version}"


class Routing:
    """See the module docstring. ``is_dead`` tells whether an SDC is declared dead: no
    measurements are mirrored to a dead backup."""

    def __init__(self, state: SdnState, messenger: Messenger, is_dead: Callable[[str], bool]) -> None:
        self.state = state
        self.messenger = messenger
        self.is_dead = is_dead
        self.group_ids: dict[int, int] = {}
        self.t_flow_change = float("-inf")

    # ------------------------------------------------------------------ flows of a path
    def flows_for(self, active: ActivePath) -> list:
        """A path's flows: both directions between the SDC and the turbine's endpoint (its IP and
        UDP port, :meth:`sdn_app.state.SdnState.endpoint`), so the turbines of one card never share
        a flow, a cookie or a group."""
        st = self.state
        wt = st.endpoint(active.wt)
        if active.sdc == st.config.primary_sdc:
            flows = fl.path_flows(hops(st.graph, active.path), st.dpids, st.host(active.sdc).ip, wt, active.cookie)
            flows = self._duplicate(active, self._guard_ingress(active, flows))
            return self._protect(active, flows + self._mirror_flows(active, flows))
        # served by a substitute SDC while addressing the primary's address
        return self._guard_ingress(active, fl.substitute_path_flows(
            hops(st.graph, active.path), st.dpids, st.addr(active.sdc), wt,
            st.addr(st.config.primary_sdc), active.cookie))

    def addressed_sdc(self) -> str:
        """The SDC whose address every turbine's packets carry: the primary's, also while a
        substitute serves it (its switch rewrites them). An L2 switch must learn *this* MAC on the
        path's uplink: after a failover it was taught the backup's, which no turbine sends to, and
        a turbine whose path a DR had moved to the other uplink stayed without control until the
        next DR re-engaged it (seen at k = 1: 100–190 ms after an SDC kill)."""
        return self.state.config.primary_sdc

    def _next_group_id(self, dpid: int) -> int:
        self.group_ids[dpid] = self.group_ids.get(dpid, 0) + 1
        return self.group_ids[dpid]

    def _protect(self, active: ActivePath, flows: list) -> list:
        """With ``fast_failover``: FF groups and detour flows for both directions of the path;
        returns group adds first (flows refer to them), then the flows."""
        st = self.state
        if not st.config.fast_failover:
            return flows
        sdc_ip, wt = st.host(active.sdc).ip, st.endpoint(active.wt)
        path = active.path if active.path[0] == active.sdc else list(reversed(active.path))
        groups, detours, out = [], [], list(flows)
        for direction, match in ((path, fl.to_turbine(sdc_ip, wt)), (list(reversed(path)), fl.from_turbine(wt, sdc_ip))):
            replace, g, d = protect_direction(st.graph, st.dpids, direction, match,
                                              active.cookie, st.down_links, self._next_group_id)
            groups += g
            detours += d
            by_dpid = {st.dpids[x]: acts for x, acts in replace.items()}
            for k, f in enumerate(out):
                if (f.dpid in by_dpid and match.items() <= f.match.items()
                        and len(f.actions) == 1 and isinstance(f.actions[0], fl.Output)):
                    out[k] = fl.FlowAdd(f.dpid, f.priority, f.match, by_dpid[f.dpid], f.cookie)
        active.groups = [(g.dpid, g.group_id) for g in groups]
        active.protected_without = frozenset(st.down_links)
        st.counters["ff_groups"] += len(groups)
        return groups + out + detours

    def _duplicate(self, active: ActivePath, flows: list) -> list:
        """With ``duplicate_paths``: the second leg's flows (:mod:`sdn_app.duplication`); a path
        without one stays single (event ``not_duplicated``)."""
        st = self.state
        if not st.config.duplicate_paths:
            return flows
        path = active.path if active.path[0] == active.sdc else list(reversed(active.path))
        leg = second_leg(st.graph, st.dpids, path, st.down_links)
        active.second_leg = leg
        active.protected_without = frozenset(st.down_links)
        if leg is None:
            st.counters["not_duplicated"] += 1
            st.event(active.installed_at, "not_duplicated", wt=active.wt, path=path,
                     down_links=sorted(sorted(k) for k in st.down_links))
            return flows
        st.counters["duplicated"] += 1
        return duplicate(st.graph, st.dpids, leg, flows, st.host(active.sdc).ip, st.endpoint(active.wt),
                         active.cookie)

    def _guard_ingress(self, active: ActivePath, flows: list) -> list:
        """Access control: on the OpenFlow switch where the turbine's packets enter, its upstream
        flow also matches the T1-registered MAC and ingress port, so a host spoofing its IP (or
        any other host) reaches only the table miss, where it is counted and dropped."""
        st = self.state
        path = active.path if active.path[-1] == active.wt else list(reversed(active.path))
        of_hops = hops(st.graph, path)
        if not of_hops:
            return flows
        ingress, _, toward_wt = of_hops[-1]
        row = st.tables.t1[active.wt]
        guarded = []
        for f in flows:
            if f.dpid == st.dpids[ingress] and f.match.get("ipv4_src") == row.ip:
                f = fl.FlowAdd(f.dpid, f.priority, {**f.match, "in_port": toward_wt, "eth_src": row.mac},
                               f.actions, f.cookie)
            guarded.append(f)
        return guarded

    def _mirror_flows(self, active: ActivePath, flows: list) -> list:
        st = self.state
        backup = st.config.backup_sdc
        if not (backup and st.config.failover and st.config.mirror_to_backup) or self.is_dead(backup):
            return []
        primary_ip = st.host(active.sdc).ip
        first_switch = active.path[1]
        to_backup = st.path_to(first_switch, backup)
        if to_backup is None or first_switch not in st.dpids:
            return []
        upstream = next((f for f in flows if f.dpid == st.dpids[first_switch] and f.match["ipv4_dst"] == primary_ip),
                        None)
        if upstream is None:
            return []
        hop_list = [(to_backup[0], 0, st.graph.edges[to_backup[0], to_backup[1]]["ports"][to_backup[0]])]
        hop_list += hops(st.graph, to_backup)
        mirrored = fl.mirror_flows(hop_list, st.dpids, upstream, st.addr(backup), st.endpoint(active.wt),
                                   active.cookie)
        # the mirror flow replaces the plain upstream flow on the first switch (same match, same priority)
        flows.remove(upstream)
        return mirrored

    # ------------------------------------------------------------------ install and remove
    def install(self, name: str, sdc: str, path: list[str], now: float) -> list:
        """Install (or move) a turbine's path: new flows first, under a new cookie version, then
        the old version's flows are deleted (make before break; on switches both paths share, the
        new flow overwrites the old one in place)."""
        st = self.state
        old = st.paths.get(name)
        version = old.reroutes + 1 if old is not None else 0
        active = ActivePath(name, sdc, path, now, fl.turbine_cookie(st.wid(name), version),
                            params=old.params if old is not None else {})
        flows = self.flows_for(active)
        active.installed = flows
        active.dpids = sorted({f.dpid for f in flows if isinstance(f, fl.FlowAdd)})
        active.reroutes = version
        st.paths[name] = active
        self.t_flow_change = now
        st.counters["flow_mods"] += sum(isinstance(f, fl.FlowAdd) for f in flows)
        changed = sorted({f.dpid for f in flows if isinstance(f, (fl.FlowAdd, fl.GroupAdd))})
        active.unacknowledged = set(changed)
        barriers = [fl.Barrier(dpid, path_tag(name, version)) for dpid in changed]
        actions = flows + barriers + self.messenger.learn_frames(list(reversed(path)) if path[0] == name else path,
                                                                 self.addressed_sdc())
        if old is not None:
            actions += self._delete(old)
        return actions

    def acknowledged(self, dpid: int, tag: str, now: float) -> str | None:
        """A switch's barrier reply for path version ``tag``: the turbine's name once every switch
        of that path has acknowledged (the path can carry packets from now on), else None."""
        name, _, version = tag.rpartition("#")
        active = self.state.paths.get(name)
        if active is None or str(active.reroutes) != version or dpid not in active.unacknowledged:
            return None  # an older version, a path since removed, or a duplicate reply
        active.unacknowledged.discard(dpid)
        if active.unacknowledged:
            return None
        active.ready_at = now
        return name

    def _delete(self, active: ActivePath) -> list:
        self.state.counters["flow_deletes"] += len(active.dpids)
        return ([fl.FlowDelete(dpid, active.cookie) for dpid in active.dpids]
                + [fl.GroupDelete(dpid, gid) for dpid, gid in active.groups])

    def remove(self, name: str) -> list:
        active = self.state.paths.pop(name, None)
        return [] if active is None else self._delete(active)

    def flows_on(self, dpid: int) -> list:
        """Every installed path's flows and groups on switch ``dpid`` (it reconnected)."""
        return [f for active in self.state.paths.values() for f in active.installed if f.dpid == dpid]

    def relearn_behind_l2(self, key: frozenset, now: float) -> list:
        """Fast failover cannot teach a non-OpenFlow switch that the SDC is now behind another
        uplink (it keeps sending the turbine's packets into the dead one, and without those packets
        no answer comes back to teach it). When such an uplink of an active path goes down, send a
        learning frame with the SDC's MAC in through every other live uplink: the switch moves the
        SDC there, and the entry detours carry the turbine's packets on."""
        st = self.state
        l2 = next((n for n in key if n not in st.dpids and n in st.config.topology.switches), None)
        if l2 is None:
            return []
        actions: list = []
        for name, active in st.paths.items():
            if key not in path_links(active.path):
                continue
            for z in sorted(st.graph.neighbors(l2)):
                if z not in st.dpids or link_key(l2, z) in st.down_links:
                    continue
                actions += self.messenger.learn_frames([z, l2, name], self.addressed_sdc())
            st.event(now, "ff_relearn", wt=name, l2=l2, link=sorted(key))
        return actions
