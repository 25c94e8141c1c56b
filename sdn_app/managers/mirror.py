"""The ``mirror`` manager (``sdn.failover`` and ``sdn.mirror_to_backup``): a copy of each
turbine's measurements to the backup SDC, a warm standby. On the path's first switch the upstream
flow gains a rewritten copy toward the backup; nothing is mirrored to a backup declared dead."""

from __future__ import annotations

from sdn_app import flows as fl
from sdn_app.managers.base import Manager
from sdn_app.paths import hops


class Mirror(Manager):
    def flows(self, routing, active, flows: list) -> list:
        st = routing.state
        backup = st.config.backup_sdc
        if not backup or routing.is_dead(backup):
            return flows
        primary_ip = st.host(active.sdc).ip
        first_switch = active.path[1]
        to_backup = st.path_to(first_switch, backup)
        if to_backup is None or first_switch not in st.dpids:
            return flows
        upstream = next((f for f in flows if f.dpid == st.dpids[first_switch] and f.match["ipv4_dst"] == primary_ip),
                        None)
        if upstream is None:
            return flows
        hop_list = [(to_backup[0], 0, st.graph.edges[to_backup[0], to_backup[1]]["ports"][to_backup[0]])]
        hop_list += hops(st.graph, to_backup)
        mirrored = fl.mirror_flows(hop_list, st.dpids, upstream, st.addr(backup), st.endpoint(active.wt),
                                   active.cookie)
        # the mirror flow replaces the plain upstream flow on the first switch (same match, same priority)
        return [f for f in flows if f is not upstream] + mirrored
