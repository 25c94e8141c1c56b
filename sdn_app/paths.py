"""The known topology as a graph (networkx) and path choice over it, failed links excluded; which
path among those left is the path policy's (:mod:`sdn_app.path_policies`)."""

from __future__ import annotations

import networkx as nx

from sdn_app.path_policies import PATH_POLICIES
from sdvisc.config import TopologyInfo


def build_graph(topology: TopologyInfo) -> nx.Graph:
    """Graph of switches and hosts; each edge knows the port on each end (``ports[node]``) and its
    one-way delay (``delay_s``, 0 when unknown and on host links)."""
    graph = nx.Graph()
    for name, sw in topology.switches.items():
        graph.add_node(name, kind="switch", dpid=sw.dpid, openflow=sw.openflow)
    for name, host in topology.hosts.items():
        graph.add_node(name, kind="host")
        graph.add_edge(name, host.switch, ports={host.switch: host.port, name: 0}, delay_s=0.0)
    for link in topology.links:
        graph.add_edge(link.a, link.b, ports={link.a: link.a_port, link.b: link.b_port}, delay_s=link.delay_s)
    return graph


def link_key(a: str, b: str) -> frozenset:
    return frozenset((a, b))


def choose_path(graph: nx.Graph, src: str, dst: str, down: set[frozenset] | frozenset = frozenset(),
                avoid: set[frozenset] | frozenset = frozenset(), nodes: set[str] | frozenset | None = None,
                policy: str = "hops") -> list[str] | None:
    """The path ``policy`` prefers from ``src`` to ``dst`` using no link in ``down`` or ``avoid``
    (and, given ``nodes``, no other node); None if there is none. The app reaches it only through
    :meth:`sdn_app.state.SdnState.path_to`, with the scenario's policy."""
    excluded = set(down) | set(avoid)
    view = nx.subgraph_view(graph, filter_node=(lambda n: n in nodes) if nodes is not None else nx.filters.no_filter,
                            filter_edge=lambda a, b: link_key(a, b) not in excluded)
    return PATH_POLICIES[policy](view, src, dst)


def path_links(path: list[str]) -> list[frozenset]:
    return [link_key(a, b) for a, b in zip(path, path[1:])]


def hops(graph: nx.Graph, path: list[str]) -> list[tuple[str, int, int]]:
    """For each OpenFlow switch on ``path``: (switch, port toward path start, port toward path end)."""
    result = []
    for i in range(1, len(path) - 1):
        node = path[i]
        data = graph.nodes[node]
        if data.get("kind") != "switch" or not data.get("openflow", True):
            continue
        back = graph.edges[path[i - 1], node]["ports"][node]
        fwd = graph.edges[node, path[i + 1]]["ports"][node]
        result.append((node, back, fwd))
    return result
