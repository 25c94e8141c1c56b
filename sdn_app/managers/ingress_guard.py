"""The ``ingress_guard`` manager (always on unless switched off): access control at the turbine's
ingress. On the OpenFlow switch where the turbine's packets enter, its upstream flow also matches
the T1-registered MAC and ingress port, so a host spoofing its IP (or any other host) reaches only
the table miss, where it is counted and dropped."""

from __future__ import annotations

from sdn_app import flows as fl
from sdn_app.managers.base import Manager
from sdn_app.paths import hops


class IngressGuard(Manager):
    ON_SUBSTITUTE_PATHS = True

    def flows(self, routing, active, flows: list) -> list:
        st = routing.state
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
