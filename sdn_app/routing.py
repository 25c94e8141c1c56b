"""Paths and their flows: install (make before break), delete, and the managers' transformations
of each path's flows (:mod:`sdn_app.managers`: ingress guard, duplication, mirror to the backup SDC,
fast-failover protection). Pure: each call returns :mod:`sdn_app.flows` actions."""

from __future__ import annotations

from collections.abc import Callable

from sdn_app import flows as fl
from sdn_app.managers.base import Manager
from sdn_app.messages import Messenger
from sdn_app.paths import hops, link_key, path_links
from sdn_app.state import ActivePath, SdnState


def path_tag(name: str, version: int) -> str:
    """The barrier tag of a turbine's path version (``wt1_1#2``)."""
    return f"{name}#{version}"


class Routing:
    """See the module docstring. ``is_dead`` tells whether an SDC is declared dead: no
    measurements are mirrored to a dead backup. ``managers``: the enabled ones, in registry order."""

    def __init__(self, state: SdnState, messenger: Messenger, is_dead: Callable[[str], bool],
                 managers: list[Manager]) -> None:
        self.state = state
        self.messenger = messenger
        self.is_dead = is_dead
        self.managers = managers
        self.group_ids: dict[int, int] = {}
        self.t_flow_change = float("-inf")

    # ------------------------------------------------------------------ flows of a path
    def flows_for(self, active: ActivePath) -> list:
        """A path's flows: both directions between the SDC and the turbine's endpoint (its IP and
        UDP port, :meth:`sdn_app.state.SdnState.endpoint`), so the turbines of one card never share
        a flow, a cookie or a group; then each manager enabled for the turbine transforms them, in
        registry order (:mod:`sdn_app.managers`: ingress guard, duplication, mirror, fast failover)."""
        st = self.state
        wt = st.endpoint(active.wt)
        substitute = active.sdc != st.config.primary_sdc
        if not substitute:
            flows = fl.path_flows(hops(st.graph, active.path), st.dpids, st.host(active.sdc).ip, wt, active.cookie)
        else:  # served by a substitute SDC while addressing the primary's address
            flows = fl.substitute_path_flows(hops(st.graph, active.path), st.dpids, st.addr(active.sdc), wt,
                                             st.addr(st.config.primary_sdc), active.cookie)
        for manager in self.managers:
            if manager.selects(active.wt) and (manager.ON_SUBSTITUTE_PATHS or not substitute):
                flows = manager.flows(self, active, flows)
        return flows

    def addressed_sdc(self) -> str:
        """The SDC whose address every turbine's packets carry: the primary's, also while a
        substitute serves it (its switch rewrites them). An L2 switch must learn *this* MAC on the
        path's uplink: after a failover it was taught the backup's, which no turbine sends to, and
        a turbine whose path a DR had moved to the other uplink stayed without control until the
        next DR re-engaged it (seen at k = 1: 100–190 ms after an SDC kill)."""
        return self.state.config.primary_sdc

    def next_group_id(self, dpid: int) -> int:
        """A new group id on switch ``dpid`` (fast-failover groups)."""
        self.group_ids[dpid] = self.group_ids.get(dpid, 0) + 1
        return self.group_ids[dpid]

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

    def relearn_behind_l2(self, key: frozenset, now: float, selects: Callable[[str], bool]) -> list:
        """Fast failover cannot teach a non-OpenFlow switch that the SDC is now behind another
        uplink (it keeps sending the turbine's packets into the dead one, and without those packets
        no answer comes back to teach it). When such an uplink of an active path goes down, send a
        learning frame with the SDC's MAC in through every other live uplink: the switch moves the
        SDC there, and the entry detours carry the turbine's packets on. Only for the turbines
        ``selects`` names (those fast failover protects)."""
        st = self.state
        l2 = next((n for n in key if n not in st.dpids and n in st.config.topology.switches), None)
        if l2 is None:
            return []
        actions: list = []
        for name, active in st.paths.items():
            if key not in path_links(active.path) or not selects(name):
                continue
            for z in sorted(st.graph.neighbors(l2)):
                if z not in st.dpids or link_key(l2, z) in st.down_links:
                    continue
                actions += self.messenger.learn_frames([z, l2, name], self.addressed_sdc())
            st.event(now, "ff_relearn", wt=name, l2=l2, link=sorted(key))
        return actions
