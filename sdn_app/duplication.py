"""1+1 duplication of a path (the ``duplication`` manager, ``sdn.duplicate_paths``): every packet also travels a second leg.

Pure. Between the path's first and last OpenFlow switch (``A`` on the SDC's side, ``B`` on the
turbine's), the second leg is the shortest way from ``A`` to ``B`` through OpenFlow switches only
that shares no switch and no link with the path between them (node-disjoint; links known down
excluded). ``A`` sends the SDC's packets out on both legs, ``B`` the turbine's; each intermediate
switch of the second leg forwards both directions; at the far end both copies reach the host, and
the receivers keep the first and drop the second by its sequence number (the SDC's
``meas_stale``, the plant's ``ctrl_stale``). This is the idea of the Parallel Redundancy Protocol
(PRP, IEC 62439-3) with the duplication and the merge done by the switches instead of doubly
attached nodes: a single failure of a link or a switch between ``A`` and ``B`` costs no packet, so
there is no repair to wait for — fast failover and DR only act where one leg is left.

Only OpenFlow switches carry the second leg: a learning (non-OpenFlow) switch that saw the SDC's
packets arrive on two ports would move its MAC entry with every packet. Where the path has fewer
than two OpenFlow switches, or no disjoint leg exists, the path is not duplicated (``None``).
The links from ``A`` to the SDC and from ``B`` toward the turbine are single points of failure,
as with fast failover.
"""

from __future__ import annotations

import networkx as nx

from sdn_app import flows as fl
from sdn_app.paths import path_links


def segment(path: list[str], dpids: dict[str, int]) -> tuple[int, int] | None:
    """Indices in ``path`` (SDC first) of its first and last OpenFlow switch, or None when there
    are fewer than two."""
    on = [i for i, n in enumerate(path) if n in dpids]
    return (on[0], on[-1]) if len(on) >= 2 else None


def second_leg(route, dpids: dict[str, int], path: list[str]) -> list[str] | None:
    """The second leg ``A … B`` for ``path`` (SDC first), or None (see the module docstring).
    ``route(src, dst, avoid=…, nodes=…)`` chooses a path around the links known down
    (:meth:`sdn_app.state.SdnState.path_to`)."""
    ends = segment(path, dpids)
    if ends is None:
        return None
    i_a, i_b = ends
    allowed = frozenset(dpids) - set(path[i_a + 1:i_b])
    leg = route(path[i_a], path[i_b], avoid=frozenset(path_links(path[i_a:i_b + 1])), nodes=allowed)
    return leg if leg is not None and len(leg) >= 2 else None


def duplicate(graph: nx.Graph, dpids: dict[str, int], leg: list[str], flows: list,
              sdc_ip: str, wt: fl.Endpoint, cookie: int) -> list:
    """``flows`` (the path's, SDC first; ``wt``: the turbine's endpoint, IP and UDP port) with the
    second leg added: the SDC → turbine flow on ``A`` and the turbine → SDC flow on ``B`` also
    output into the leg; the leg's own switches forward both directions."""
    a, b = leg[0], leg[-1]
    wt_ip = wt[0]
    leg_hops = _leg_hops(graph, leg)
    extra_out = {(dpids[a], sdc_ip, wt_ip): leg_hops[0][2], (dpids[b], wt_ip, sdc_ip): leg_hops[-1][1]}
    out = []
    for f in flows:
        key = (f.dpid, f.match.get("ipv4_src"), f.match.get("ipv4_dst"))
        if isinstance(f, fl.FlowAdd) and key in extra_out and f.priority == fl.PRIORITY_PATH:
            f = fl.FlowAdd(f.dpid, f.priority, f.match, f.actions + (fl.Output(extra_out.pop(key)),), f.cookie)
        out.append(f)
    if extra_out:
        raise ValueError(f"path flows lack the leg's end flows {sorted(extra_out)}")
    for switch, toward_a, toward_b in leg_hops[1:-1]:
        dpid = dpids[switch]
        out.append(fl.FlowAdd(dpid, fl.PRIORITY_PATH, fl.to_turbine(sdc_ip, wt), (fl.Output(toward_b),), cookie))
        out.append(fl.FlowAdd(dpid, fl.PRIORITY_PATH, fl.from_turbine(wt, sdc_ip), (fl.Output(toward_a),), cookie))
    return out


def _leg_hops(graph: nx.Graph, leg: list[str]) -> list[tuple[str, int, int]]:
    """(switch, port toward A, port toward B) for every switch of the leg; ``A`` has no port toward
    A (0) and ``B`` none toward B (0)."""
    result = []
    for i, node in enumerate(leg):
        back = graph.edges[leg[i - 1], node]["ports"][node] if i > 0 else 0
        fwd = graph.edges[node, leg[i + 1]]["ports"][node] if i < len(leg) - 1 else 0
        result.append((node, back, fwd))
    return result
