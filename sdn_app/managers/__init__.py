"""The SDN managers (FAUCET's valve managers are the model, :mod:`sdn_app.managers.base`): the
registry, in the order their :meth:`~sdn_app.managers.base.Manager.flows` hooks transform a path's
flows, and the managers a configuration enables.

A scenario enables them with ``sdn.managers`` (per-turbine selectors) or the older booleans, mapped
in one place (:meth:`sdvisc.config.SdnOptions.manager_selection`). A new manager is its module and
one line here.
"""

from __future__ import annotations

from sdn_app.managers.base import Manager
from sdn_app.managers.duplication import Duplication
from sdn_app.managers.dynamic_routing import DynamicRouting
from sdn_app.managers.fast_failover import FastFailover
from sdn_app.managers.ingress_guard import IngressGuard
from sdn_app.managers.mirror import Mirror
from sdn_app.managers.port_status_reroute import PortStatusReroute

MANAGERS: dict[str, type[Manager]] = {
    "ingress_guard": IngressGuard,
    "duplication": Duplication,
    "mirror": Mirror,
    "fast_failover": FastFailover,
    "port_status_reroute": PortStatusReroute,
    "dynamic_routing": DynamicRouting,
}


def enabled_managers(selection: dict[str, frozenset[str] | None], turbines: set[str]) -> list[Manager]:
    """The managers of ``selection`` (name -> turbines or None: every turbine, from
    :meth:`sdvisc.config.SdnOptions.manager_selection`), in registry order. ``turbines``: the
    topology's; a selector naming another is an error, as is an unknown manager."""
    unknown = sorted(set(selection) - set(MANAGERS))
    if unknown:
        raise ValueError(f"sdn.managers: unknown manager(s) {unknown}; known: {sorted(MANAGERS)}")
    for name, chosen in selection.items():
        stray = sorted((chosen or frozenset()) - turbines)
        if stray:
            raise ValueError(f"sdn.managers: {name}: {stray} not turbine(s) of the topology")
    return [cls(selection[name]) for name, cls in MANAGERS.items() if name in selection]
