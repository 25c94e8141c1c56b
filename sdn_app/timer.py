"""When the app's timer ticks next (pure: simulated seconds in, simulated seconds out).

The timer runs :meth:`sdn_app.logic.Controller.tick` — the decisions no packet triggers: an SDC
silent for ``sdc_dead_s``, a turbine whose AKs stopped for ``ak_timeout_s`` and whose loss lasted
the hold. Each wake-up of the app's timer thread costs tens of microseconds of CPU on a 2-core VM
(more than the tick itself), so it ticks every :data:`TICK_S` only while a decision may be due and
sleeps up to :data:`QUIET_TICK_S` otherwise (:func:`wait_s`).
"""

from __future__ import annotations

TICK_S = 0.002
"""The timer's period while a decision may be due (a loss in progress, a suspected SDC, a path
awaiting its acknowledgements, the controller's own stall)."""

QUIET_TICK_S = 0.010
"""The longest the timer sleeps while nothing can be due. Every timed decision needs at least
``ak_timeout_s`` or ``sdc_dead_s`` (30 ms) of silence, which :meth:`Controller.next_decision_at`
bounds from below, so it still comes at a :data:`TICK_S` tick. Only a state that a packet makes
pending without deciding itself (an AK = 0 whose DR waits for its SDC's verdict) is ticked up to
this much later than at :data:`TICK_S`; idle, the app wakes ~100 times a second instead of 500."""


def wait_s(now: float, next_decision_at: float, next_publish_at: float = float("inf")) -> float:
    """Simulated seconds to sleep after a tick at ``now``: until the next possible decision or
    the next state publication, at most :data:`QUIET_TICK_S`, at least :data:`TICK_S`."""
    return max(TICK_S, min(QUIET_TICK_S, next_decision_at - now, next_publish_at - now))
