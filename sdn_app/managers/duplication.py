"""The ``duplication`` manager (``sdn.duplicate_paths``): 1+1, every packet also on a second leg
(:mod:`sdn_app.duplication`); when a link of a duplicated path goes down, the path gets two legs
again as the network now allows."""

from __future__ import annotations

from sdn_app.duplication import duplicate, second_leg
from sdn_app.managers.base import Manager
from sdn_app.paths import path_links


class Duplication(Manager):
    LINK_ORDER = 30  # after the reroutes: a path they moved already is not touched twice

    def flows(self, routing, active, flows: list) -> list:
        """The second leg's flows; a path without one stays single (event ``not_duplicated``)."""
        st = routing.state
        path = active.path if active.path[0] == active.sdc else list(reversed(active.path))
        leg = second_leg(st.path_to, st.dpids, path)
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

    def on_link(self, recovery, key: frozenset, up: bool, now: float) -> list:
        """A link of a duplicated path went down: the packets still arrive over the other leg (no
        loss, so no DR); give the path two legs again, as the network now allows (make before
        break, the DR hold untouched). A path with one leg only lost its packets: that is the DR's
        (or fast failover's) to repair, as without duplication. A path already moved by a reroute
        at this moment (``port_status_reroute``) is not touched twice."""
        if up:
            return []
        st = recovery.state
        actions: list = []
        for name, active in sorted(st.paths.items()):
            if (active.second_leg is None or name in recovery.partitioned or active.installed_at == now
                    or not self.selects(name)):
                continue
            if key not in path_links(active.path) + path_links(active.second_leg):
                continue
            path = st.path_to(active.sdc, name)
            if path is None:
                continue  # nothing left to pair: the DR machinery reports the loss
            actions += recovery.routing.install(name, active.sdc, path, now)
            st.counters["pairs_repaired"] += 1
            st.event(now, "pair_repaired", wt=name, link=sorted(key), path=path, second_leg=st.paths[name].second_leg)
        return actions
