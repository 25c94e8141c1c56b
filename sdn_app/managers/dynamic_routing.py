"""The ``dynamic_routing`` manager (``sdn.dynamic_routing``, on by default): act on a confirmed
``DR_i`` by rerouting (:meth:`sdn_app.recovery.Recovery.reroute`). A turbine it does not act for
is logged ``dr_not_acted`` only (the paper's case without DR)."""

from __future__ import annotations

from sdn_app.managers.base import Manager


class DynamicRouting(Manager):
    def on_dr(self, recovery, name: str, t_loss: float, now: float) -> list | None:
        return recovery.reroute(name, "dr", now, t_loss=t_loss)
