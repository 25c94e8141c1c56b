"""Path policies: how a path is chosen among the links that are up (the registry).

A policy is a function ``choose(view, src, dst) -> list[str] | None``: the node sequence of the
path it prefers from ``src`` to ``dst`` in ``view`` (the topology graph with the links down or to
avoid already taken out, :func:`sdn_app.paths.choose_path`), or None when there is none. Ties are
broken deterministically (the lexicographically smallest node sequence) so a run is reproducible.
Every path the app installs (a turbine's path, a fast-failover detour, a duplicated path's second
leg, the mirror's way to the backup SDC) is chosen by the scenario's ``sdn.path_policy`` through
:meth:`sdn_app.state.SdnState.path_to`.

A new policy is its module and one line here.
"""

from __future__ import annotations

from sdn_app.path_policies import delay, hops

PATH_POLICIES = {
    "hops": hops.choose,
    "delay": delay.choose,
}
