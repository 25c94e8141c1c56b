"""Where each node of a topology goes among a cluster's servers: Mininet ``Placer`` subclasses for
:class:`topologies.cluster.ClusterNet` (``placement=``; ``functools.partial`` for options).

* :class:`FarmPlacer` — by farm cluster; :class:`RolePlacer` — by role; :class:`DictPlacer` — explicit.
"""

from __future__ import annotations

import re
from collections import Counter

from mininet.examples.cluster import Placer

TURBINE_RE = re.compile(r"^wt(\d+)_(\d+)$")



class _TopoPlacer(Placer):
    """Base of the project's placers: a host without a rule goes with its switch, a switch without a
    rule to ``default`` (the first server unless given)."""

    def __init__(self, *args, topo=None, default=None, **kwargs):
        super().__init__(*args, **kwargs)
        self.topo = topo
        self.default = default or self.servers[0]
        self.hset, self.sset = set(self.hosts), set(self.switches)
        self.switch_of: dict[str, str] = {}
        self.hosts_of: dict[str, list[str]] = {s: [] for s in self.switches}
        for a, b in self.links:
            for h, s in ((a, b), (b, a)):
                if h in self.hset and s in self.sset:
                    self.switch_of.setdefault(h, s)
                    self.hosts_of[s].append(h)
        self.placement: dict[str, str] = {}

    def rule(self, node: str) -> str | None:
        return None

    def place(self, node):
        if node not in self.placement:
            server = self.rule(node)
            if server is None:
                if node in self.hset and node in self.switch_of:
                    server = self.place(self.switch_of[node])
                else:
                    server = self.default
            self.placement[node] = server
        return self.placement[node]


class FarmPlacer(_TopoPlacer):
    """By farm cluster: turbine ``wt<c>_<n>`` on server ``(c - 1) mod N`` of the N servers (cluster 1
    on the first), a switch with turbines on the server of its lowest cluster (a cluster switch
    ``c<k>``, a tower switch, the paper's ``l2``), every other switch (substation, ring, intake) on
    ``core`` (default: the last server, so that with two servers the clusters' switches and the core
    are apart), every other host with its switch."""

    def __init__(self, *args, core=None, **kwargs):
        super().__init__(*args, **kwargs)
        self.default = core or self.servers[-1]

    def cluster_server(self, cluster: int) -> str:
        return self.servers[(cluster - 1) % len(self.servers)]

    def rule(self, node):
        if m := TURBINE_RE.match(node):
            return self.cluster_server(int(m.group(1)))
        if node in self.sset:
            clusters = [int(m.group(1)) for h in self.hosts_of[node] if (m := TURBINE_RE.match(h))]
            if clusters:
                return self.cluster_server(min(clusters))
        return None


class RolePlacer(_TopoPlacer):
    """By role: ``roles`` maps a host's role (``turbine``, ``service``, ``impairment``, ``intake``) to
    a server; a switch goes where most of its hosts are (else ``default``); a host whose role is not
    in ``roles`` goes with its switch."""

    def __init__(self, *args, roles=None, **kwargs):
        super().__init__(*args, **kwargs)
        self.roles = dict(roles or {})

    def rule(self, node):
        if node in self.hset:
            role = self.topo.nodeInfo(node).get("role") if self.topo is not None else None
            return self.roles.get(role)
        servers = Counter(self.roles[r] for h in self.hosts_of.get(node, ())
                          if self.topo is not None and (r := self.topo.nodeInfo(h).get("role")) in self.roles)
        return servers.most_common(1)[0][0] if servers else None


class DictPlacer(_TopoPlacer):
    """Explicit: ``placement`` maps node names to servers; others as :class:`_TopoPlacer`."""

    def __init__(self, *args, placement=None, **kwargs):
        super().__init__(*args, **kwargs)
        self.explicit = dict(placement or {})

    def rule(self, node):
        return self.explicit.get(node)
