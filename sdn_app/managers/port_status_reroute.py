"""The ``port_status_reroute`` manager (``sdn.reroute_on_port_status``): a path whose link went
down (a port-status message) is rerouted at once, without waiting for the DR."""

from __future__ import annotations

from sdn_app.managers.base import Manager
from sdn_app.paths import path_links


class PortStatusReroute(Manager):
    LINK_ORDER = 20

    def on_link(self, recovery, key: frozenset, up: bool, now: float) -> list:
        if up:
            return []
        actions: list = []
        for name, active in list(recovery.state.paths.items()):
            if key in path_links(active.path) and name not in recovery.partitioned and self.selects(name):
                actions += recovery.reroute(name, "port_status", now, t_loss=None)
        return actions
