"""Dynamic routing and partitions: the app's reaction when a ViSC turbine loses its control
packets (``DR_i``, confirmed by :mod:`sdn_app.dr`), when a link of a path goes down or comes up,
and when no path is left. Pure: each call takes ``now`` and returns :mod:`sdn_app.flows` actions.

* **DR**: reroute around the failure — avoid links known down (port status), else take a path
  link-disjoint from the current one (the two host links excepted); for a turbine without the
  ``dynamic_routing`` manager, log ``dr_not_acted`` only (the paper's "without DR").
* **Links**: the managers' ``on_link`` hooks (:mod:`sdn_app.managers`), then healing and reprotection.
* **Partition**: no path → one ``no_path`` event, T3 ``x/0``, nothing retried until a link comes up;
  then the path is installed again (``path_restored``) and the turbine re-engaged.
"""

from __future__ import annotations

from sdn_app.messages import Messenger
from sdn_app.paths import link_key, path_links
from sdn_app.routing import Routing
from sdn_app.state import SdnState


class Recovery:
    """See the module docstring."""

    def __init__(self, state: SdnState, routing: Routing, messenger: Messenger) -> None:
        self.state = state
        self.routing = routing
        self.messenger = messenger
        self.managers = routing.managers
        self._by_link_order = sorted(self.managers, key=lambda m: m.LINK_ORDER)  # (stable: registry order within one)
        self.partitioned: dict[str, float] = {}  # turbines with no path to their SDC, since (t_loss)

    def on_dr(self, due: list[tuple[str, float]], now: float) -> list:
        """Act on the turbines whose DR is confirmed: the first manager enabled for the turbine
        that acts (``dynamic_routing``); without one, log ``dr_not_acted`` only."""
        st = self.state
        actions: list = []
        for name, t_loss in due:
            acted = None
            for manager in self.managers:
                if manager.selects(name) and (acted := manager.on_dr(self, name, t_loss, now)) is not None:
                    break
            if acted is not None:
                actions += acted
            else:
                st.tables.set_comm(name, comm_on=False)
                st.event(now, "dr_not_acted", wt=name, t_loss=t_loss, reason="dynamic routing off")
        return actions

    def on_link(self, key: frozenset, up: bool, now: float) -> list:
        """A link changed state: each manager's reaction (:attr:`~sdn_app.managers.base.Manager.LINK_ORDER`:
        fast failover's relearning, the reroute on port status, the repair of duplicated paths),
        then, when it came up, partitions healed and paths protected again."""
        actions: list = []
        for manager in self._by_link_order:
            actions += manager.on_link(self, key, up, now)
        if up:
            actions += self.heal(now)
            actions += self.reprotect(key, now)
        return actions

    def reprotect(self, key: frozenset, now: float) -> list:
        """A link came back: a path whose fast-failover detours were computed while it was down
        has no detour through it (after a DR around an L2 uplink, the other uplink's failure would
        go unprotected). Install the same path again, protected with the link (make before break)."""
        st = self.state
        actions: list = []
        for name, active in sorted(st.paths.items()):
            if key in active.protected_without and name not in self.partitioned:
                actions += self.routing.install(name, active.sdc, active.path, now)
                st.counters["reprotected"] += 1
                st.event(now, "reprotected", wt=name, link=sorted(key), path=active.path)
        return actions

    def reroute(self, name: str, cause: str, now: float, t_loss: float | None) -> list:
        st = self.state
        active = st.paths[name]
        current = set(path_links(active.path))
        known_bad = current & st.down_links
        host_links = {link_key(active.path[0], active.path[1]), link_key(active.path[-2], active.path[-1])}
        avoid = frozenset() if known_bad else frozenset(current - host_links)
        new_path = st.path_to(active.sdc, name, avoid=avoid)
        if new_path is None and avoid:
            candidate = st.path_to(active.sdc, name)
            new_path = candidate if candidate != active.path else None
        st.dr.start(name, now, await_path=True)
        if new_path is None:
            return self._no_path(name, cause, now, t_loss)
        streak = st.dr.tracks[name].streak if name in st.dr.tracks else 0
        actions = self.routing.install(name, active.sdc, new_path, now)
        st.tables.set_comm(name, link_ok=True)
        st.counters[f"reroute_{cause}"] += 1
        # a loss longer than the turbine's fallback time left it on its own control and the SDC's
        # instance running open loop; a repeated DR says the path was not the problem: start both again
        reengage = streak > 1 or (t_loss is not None and now - t_loss >= st.config.turbine_fallback_s)
        ak = st.dr.tracks.get(name)  # the AK stream the decision rests on (sdn_app.ak_streams): its last seq
        st.event(now, cause, wt=name, t_loss=t_loss, t_detect=now, old_path=active.path, new_path=new_path,
                 avoided="known down links" if known_bad else "current path (link-disjoint)", reengaged=reengage,
                 ak_seq=ak.seq if ak is not None else None)
        if reengage:
            actions += self.messenger.reengage(name, active.sdc, now)
        return actions

    def _no_path(self, name: str, cause: str, now: float, t_loss: float | None) -> list:
        """No path to the turbine's SDC: reported once, T3 x/0; the turbine falls back on its own
        (as without DR) and nothing is retried until the topology changes (:meth:`heal`)."""
        st = self.state
        if name not in self.partitioned:
            self.partitioned[name] = t_loss if t_loss is not None else now
            st.tables.set_comm(name, comm_on=False, link_ok=False)
            st.counters["no_path"] += 1
            st.event(now, "no_path", wt=name, cause=cause, t_loss=t_loss, t_detect=now,
                     down_links=sorted(sorted(k) for k in st.down_links))
        return []

    def heal(self, now: float) -> list:
        """A link came up: give every partitioned turbine a path if one exists now."""
        st = self.state
        actions: list = []
        for name, t_loss in sorted(self.partitioned.items()):
            active = st.paths.get(name)
            if active is None or name not in st.tables.t1:
                self.partitioned.pop(name)
                continue
            path = st.path_to(active.sdc, name)
            if path is None:
                continue
            self.partitioned.pop(name)
            actions += self.routing.install(name, active.sdc, path, now)
            st.tables.set_comm(name, link_ok=True)
            st.dr.start(name, now, await_path=True)
            st.counters["path_restored"] += 1
            st.event(now, "path_restored", wt=name, t_loss=t_loss, t_detect=now, new_path=path)
            actions += self.messenger.reengage(name, active.sdc, now)
        return actions

    def forget(self, name: str) -> None:
        """The turbine left ViSC (or the network): no partition to heal for it."""
        self.partitioned.pop(name, None)
