"""Path choice over the known topology (networkx), with failed links excluded."""

from __future__ import annotations

import networkx as nx

from sdvisc.config import TopologyInfo


def build_graph(topology: TopologyInfo) -> nx.Graph:
    """Graph of switches and hosts; each edge knows the port on each end (``ports[node]``)."""
    graph = nx.Graph()
    for name, sw in topology.switches.items():
        graph.add_node(name, kind="switch", dpid=sw.dpid, openflow=sw.openflow)
    for name, host in topology.hosts.items():
        graph.add_node(name, kind="host")
        graph.add_edge(name, host.switch, ports={host.switch: host.port, name: 0})
    for link in topology.links:
        graph.add_edge(link.a, link.b, ports={link.a: link.a_port, link.b: link.b_port})
    return graph


def link_key(a: str, b: str) -> frozenset:
    return frozenset((a, b))


def choose_path(graph: nx.Graph, src: str, dst: str, down: set[frozenset] | frozenset = frozenset(),
                avoid: set[frozenset] | frozenset = frozenset()) -> list[str] | None:
    """Shortest path ``src`` → ``dst`` that uses no link in ``down`` or ``avoid``; None if none.

    Ties are broken deterministically (lexicographically smallest node sequence) so a run is
    reproducible.
    """
    excluded = set(down) | set(avoid)
    view = nx.subgraph_view(graph, filter_edge=lambda a, b: link_key(a, b) not in excluded)
    try:
        paths = list(nx.all_shortest_paths(view, src, dst))
    except (nx.NetworkXNoPath, nx.NodeNotFound):
        return None
    return min(paths)


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
