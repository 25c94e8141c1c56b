"""Fast-failover protection of a path: OpenFlow FF groups with watch ports plus detour flows.

Pure. For each direction of a path and each OpenFlow switch X on it, the detour is the shortest
path from X to the destination that avoids the link X→next (and links known down). X forwards
through a fast-failover group: bucket 1 watches and uses the primary port, bucket 2 the detour's
first port (``IN_PORT`` when the detour goes back the way the packet came). Switches along the
detour get higher-priority flows that also match the port the detoured packet arrives on, so they
never divert the primary traffic; the detour flows stop where the detour rejoins the primary path
downstream of the protected link (from there the primary flows already lead to the destination).
The data plane then switches within the time Open vSwitch needs to see the port go down, before
the controller acts; the AK/DR machinery still runs and later moves the path properly.
"""

from __future__ import annotations

import networkx as nx

from sdn_app import flows as fl
from sdn_app.paths import link_key


def _port(graph: nx.Graph, a: str, b: str) -> int:
    return graph.edges[a, b]["ports"][a]


def protect_direction(graph: nx.Graph, dpids: dict[str, int], path: list[str], match: dict, cookie: int,
                      down: set, next_group_id, route) -> tuple[dict[str, tuple], list, list]:
    """Protection for packets travelling along ``path`` (host to host) with ``match``.

    Returns (group action per switch to use instead of its primary output, group adds, detour
    flow adds). ``next_group_id(dpid)`` allocates group ids; ``route(src, dst, avoid=…)`` chooses
    a path around the links ``down`` (:meth:`sdn_app.state.SdnState.path_to`).
    """
    replace: dict[str, tuple] = {}
    groups: list = []
    detours: list = []
    on_path = {n: i for i, n in enumerate(path)}
    # entry through a non-OpenFlow (learning) switch: it may send the packets to any of its
    # OpenFlow neighbours (it follows where it last saw the destination), so each of them gets an
    # entry detour toward the destination
    entry = path[1]
    if entry not in dpids and graph.nodes[entry].get("kind") == "switch":
        for z in sorted(graph.neighbors(entry)):
            if z not in dpids or z == path[2] or link_key(entry, z) in down:
                continue
            way = route(z, path[-1])
            if way is None:
                continue
            detours += _detour_flows(graph, dpids, [entry] + way, match, cookie, on_path, rejoin_after=1)
    for i in range(1, len(path) - 1):
        x = path[i]
        if x not in dpids:
            continue
        pred, succ = path[i - 1], path[i + 1]
        protected = link_key(x, succ)
        if graph.nodes[succ].get("kind") == "host":
            continue  # the last hop to a host cannot be protected
        detour = route(x, path[-1], avoid=frozenset({protected}))
        if detour is None or len(detour) < 2:
            continue
        first = detour[1]
        backup_out = fl.Output(fl.IN_PORT) if first == pred else fl.Output(_port(graph, x, first))
        gid = next_group_id(dpids[x])
        groups.append(fl.GroupAdd(dpids[x], gid, (
            (_port(graph, x, succ), (fl.Output(_port(graph, x, succ)),)),
            (_port(graph, x, first), (backup_out,)),
        )))
        replace[x] = (fl.Group(gid),)
        detours += _detour_flows(graph, dpids, detour, match, cookie, on_path, rejoin_after=i)
    return replace, groups, detours


def _detour_flows(graph: nx.Graph, dpids: dict[str, int], detour: list[str], match: dict, cookie: int,
                  on_path: dict[str, int], rejoin_after: int) -> list:
    """In-port-specific flows along ``detour`` (from its second node) until it rejoins the primary
    path beyond position ``rejoin_after``."""
    flows = []
    for j in range(1, len(detour) - 1):
        y = detour[j]
        if on_path.get(y, -1) > rejoin_after:
            break  # rejoined the primary path beyond the protected link
        if y not in dpids:
            continue
        in_port = _port(graph, y, detour[j - 1])
        out_port = _port(graph, y, detour[j + 1])
        out = fl.Output(fl.IN_PORT) if out_port == in_port else fl.Output(out_port)
        flows.append(fl.FlowAdd(dpids[y], fl.PRIORITY_DETOUR, {**match, "in_port": in_port}, (out,), cookie))
    return flows
