"""What every SDN manager is: hooks the app calls, each returning :mod:`sdn_app.flows` actions.

FAUCET's valve managers are the model (each concern one object whose hooks return the OpenFlow
messages for an event, the valve running every enabled one in a fixed order); here the hooks are:

* :meth:`Manager.flows` — a turbine's path is being installed: transform its flows (add matches,
  outputs, groups, detour or copy flows). Run in :data:`sdn_app.managers.MANAGERS` order.
* :meth:`Manager.on_link` — a link went down or came up. Run in :attr:`Manager.LINK_ORDER` order.
* :meth:`Manager.on_dr` — a turbine's ``DR_i`` is confirmed: act, or None to leave it to the next.

Each hook is pure in the app's sense: it reads and records on the shared state
(:class:`sdn_app.state.SdnState`, through the ``routing`` or ``recovery`` it is given), takes
``now`` where it records, and returns actions; nothing touches a socket or a clock. A manager
acts only for the turbines it was enabled for (``sdn.managers``' selectors, :meth:`selects`).
"""

from __future__ import annotations


class Manager:
    """A manager that does nothing; subclasses override the hooks they need."""

    ON_SUBSTITUTE_PATHS = False
    """Whether :meth:`flows` also applies to a path served by a substitute SDC (after a failover)."""
    LINK_ORDER = 100
    """Where :meth:`on_link` runs among the managers (lower first): data-plane repair, then
    reroutes, then what depends on the reroutes having been made."""

    def __init__(self, turbines: frozenset[str] | None = None) -> None:
        self.turbines = turbines

    def selects(self, name: str) -> bool:
        """Whether this manager acts for turbine ``name`` (None: for every turbine)."""
        return self.turbines is None or name in self.turbines

    # the hooks' ``routing`` is the app's :class:`sdn_app.routing.Routing`, ``recovery`` its
    # :class:`sdn_app.recovery.Recovery`, ``active`` an :class:`sdn_app.state.ActivePath` (not
    # imported: they run the managers)
    def flows(self, routing, active, flows: list) -> list:
        return flows

    def on_link(self, recovery, key: frozenset, up: bool, now: float) -> list:
        return []

    def on_dr(self, recovery, name: str, t_loss: float, now: float) -> list | None:
        return None
