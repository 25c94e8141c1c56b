"""The ``fast_failover`` manager (``sdn.fast_failover``): OpenFlow fast-failover groups and detour
flows protect both directions of a path (:mod:`sdn_app.protection`), so the data plane repairs a
failed link before the controller acts; when a link down is an uplink of a non-OpenFlow switch on
a path, that switch is taught where the SDC now is (:meth:`sdn_app.routing.Routing.relearn_behind_l2`)."""

from __future__ import annotations

from sdn_app import flows as fl
from sdn_app.managers.base import Manager
from sdn_app.protection import protect_direction


class FastFailover(Manager):
    LINK_ORDER = 10  # the data plane's repair first: before any reroute moves the path

    def flows(self, routing, active, flows: list) -> list:
        """Groups first (flows refer to them), then the flows with each protected output replaced
        by its group, then the detours."""
        st = routing.state
        sdc_ip, wt = st.host(active.sdc).ip, st.endpoint(active.wt)
        path = active.path if active.path[0] == active.sdc else list(reversed(active.path))
        groups, detours, out = [], [], list(flows)
        for direction, match in ((path, fl.to_turbine(sdc_ip, wt)), (list(reversed(path)), fl.from_turbine(wt, sdc_ip))):
            replace, g, d = protect_direction(st.graph, st.dpids, direction, match, active.cookie, st.down_links,
                                              routing.next_group_id, st.path_to)
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

    def on_link(self, recovery, key: frozenset, up: bool, now: float) -> list:
        if up:
            return []
        return recovery.routing.relearn_behind_l2(key, now, self.selects)
