"""The ``delay`` path policy: the least summed one-way link delay, then the fewest hops.

Each edge's ``delay_s`` comes from the topology (:class:`sdvisc.config.LinkInfo`, from its link
options; host links and links of unknown delay carry 0). The cost is exact integer arithmetic so
ties are ties: an edge costs ``delay_ns · M + 1`` with ``M`` larger than any path's hop count, so a
path's cost orders first by its summed delay (to the nanosecond) and then by its hops. With no
delay known this is the ``hops`` policy, path for path.
"""

from __future__ import annotations

import networkx as nx


def choose(view: nx.Graph, src: str, dst: str) -> list[str] | None:
    """The path of least delay, of fewest hops among those, the lexicographically smallest."""
    per_ns = view.number_of_edges() + 1  # > any simple path's hop count

    def cost(a: str, b: str, data: dict) -> int:
        return round(data.get("delay_s", 0.0) * 1e9) * per_ns + 1

    try:
        return min(nx.all_shortest_paths(view, src, dst, weight=cost))
    except (nx.NetworkXNoPath, nx.NodeNotFound):
        return None
