"""The ``hops`` path policy (the default, the paper's): the fewest hops."""

from __future__ import annotations

import networkx as nx


def choose(view: nx.Graph, src: str, dst: str) -> list[str] | None:
    """A path with the fewest hops, the lexicographically smallest of them."""
    try:
        return min(nx.all_shortest_paths(view, src, dst))
    except (nx.NetworkXNoPath, nx.NodeNotFound):
        return None
