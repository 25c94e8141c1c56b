"""SDC liveness as a detector, not a fixed timeout: pure code, ``now`` passed in.

Each SDC sends a heartbeat every ~10 ms. On a loaded machine the heartbeats' arrival times jitter
by tens of milliseconds (they are packet-ins through the same busy Open vSwitch thread as
everything else), so "no heartbeat for 30 ms" is not evidence of death. Here, per SDC:

* the inter-arrival times actually observed are kept (last :data:`WINDOW` of them) and the
  silence after the last heartbeat is judged against that distribution, phi-accrual style
  (Hayashibara et al., 2004): ``phi = −log10 P(an interval this long)`` under a normal fit with a
  floor on the spread. The SDC is **suspected** when the silence exceeds ``suspect_phi`` (about one
  missed heartbeat on a steady stream) and **silent** when it exceeds both the configured
  ``sdc_dead_s`` and ``dead_phi`` (several missed heartbeats, more on a jittery stream);
* silence is counted from the last heartbeat or from the end of the controller's last stall (a
  moment when nothing at all had arrived for a while), whichever is later;
* a silent SDC is declared **dead** only with corroboration, decided by the caller: every turbine it
  serves reports a loss of control packets (their own AK), and not every SDC is silent at once (that
  is a stall of ours or of the switches, not two deaths);
* **hysteresis**: a dead SDC is alive again only after :data:`ALIVE_AFTER` consecutive heartbeats;
* a heartbeat counter that goes back (1 after 5000) means the process restarted: reported once.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

from sdvisc.counter_gate import CounterGate

WINDOW = 200
"""Inter-arrival times kept per SDC."""
MIN_SAMPLES = 10
"""Below this many intervals the nominal heartbeat period stands in for the observed ones."""
HEARTBEAT_MAX_STEP = 100
"""Heartbeat counter steps accepted without confirmation (about 1 s of heartbeats)."""
ALIVE_AFTER = 3
"""Consecutive heartbeats that bring a dead SDC back."""


@dataclass
class HeartbeatTrack:
    """Heartbeat history of one SDC."""

    t_last: float | None = None
    seq: int = 0
    gate: CounterGate = field(default_factory=lambda: CounterGate(HEARTBEAT_MAX_STEP))
    intervals: deque = field(default_factory=lambda: deque(maxlen=WINDOW))
    since_dead: int = 0
    restarts: int = 0


class SdcLiveness:
    """Suspicion levels of each SDC from its heartbeats (see the module docstring)."""

    def __init__(self, period_s: float = 0.010, sdc_dead_s: float = 0.030, suspect_phi: float = 3.0,
                 dead_phi: float = 8.0, min_sigma_s: float = 0.002) -> None:
        if period_s <= 0 or sdc_dead_s <= 0 or not 0 < suspect_phi < dead_phi or min_sigma_s <= 0:
            raise ValueError("period_s, sdc_dead_s and min_sigma_s must be positive, 0 < suspect_phi < dead_phi")
        self.period_s = period_s
        self.sdc_dead_s = sdc_dead_s
        self.suspect_phi = suspect_phi
        self.dead_phi = dead_phi
        self.min_sigma_s = min_sigma_s
        self.tracks: dict[str, HeartbeatTrack] = {}
        self.dead: set[str] = set()

    def known(self) -> list[str]:
        return sorted(self.tracks)

    def on_heartbeat(self, sdc: str, seq: int, now: float, resumed: float = float("-inf")) -> list[str]:
        """Record one heartbeat received at ``now``; returns what it changed: ``"restarted"`` (the
        counter went back) and/or ``"alive"`` (a dead SDC came back, after hysteresis). An
        interval across the end of a controller stall (``resumed``) is not this SDC's jitter and is
        left out of the distribution."""
        t = self.tracks.setdefault(sdc, HeartbeatTrack())
        changes = []
        previous = t.gate.last
        verdict = t.gate.admit(seq)
        if not t.gate.accepts(verdict):
            return changes  # duplicate, reordered, or a jump not confirmed (yet): no new evidence
        if verdict == "resync" and previous is not None and seq < previous:
            t.restarts += 1  # the counter went back and a second heartbeat confirmed it
            changes.append("restarted")
        t.seq = seq
        if t.t_last is not None and now > t.t_last and t.t_last >= resumed:
            t.intervals.append(now - t.t_last)
        t.t_last = now if t.t_last is None else max(t.t_last, now)
        if sdc in self.dead:
            t.since_dead += 1
            if t.since_dead >= ALIVE_AFTER:
                self.dead.discard(sdc)
                t.since_dead = 0
                changes.append("alive")
        return changes

    def _fit(self, t: HeartbeatTrack) -> tuple[float, float]:
        if len(t.intervals) < MIN_SAMPLES:
            return self.period_s, max(self.min_sigma_s, self.period_s / 4)
        n = len(t.intervals)
        mean = sum(t.intervals) / n
        var = sum((x - mean) ** 2 for x in t.intervals) / n
        return mean, max(math.sqrt(var), self.min_sigma_s)

    def phi(self, sdc: str, now: float, resumed: float = float("-inf")) -> float:
        """Suspicion: −log10 of the probability that a heartbeat interval is at least this long."""
        t = self.tracks.get(sdc)
        if t is None or t.t_last is None:
            return 0.0
        mean, sigma = self._fit(t)
        silence = self.silence(sdc, now, resumed)
        p_later = 0.5 * math.erfc((silence - mean) / (sigma * math.sqrt(2.0)))
        return -math.log10(max(p_later, 1e-300))

    def silence(self, sdc: str, now: float, resumed: float = float("-inf")) -> float:
        """How long the SDC has been silent, counted from its last heartbeat or from ``resumed``
        (the end of the controller's last stall: nothing at all arrived before it, so a silence
        across it says nothing about this SDC), whichever is later."""
        t = self.tracks.get(sdc)
        return 0.0 if t is None or t.t_last is None else now - max(t.t_last, resumed)

    def suspected(self, sdc: str, now: float, resumed: float = float("-inf")) -> bool:
        """At least about one heartbeat is overdue."""
        return self.silence(sdc, now, resumed) > self.period_s and self.phi(sdc, now, resumed) >= self.suspect_phi

    def silent(self, sdc: str, now: float, resumed: float = float("-inf")) -> bool:
        """Overdue beyond both the configured timeout and the observed jitter (death candidate)."""
        return (self.silence(sdc, now, resumed) >= self.sdc_dead_s
                and self.phi(sdc, now, resumed) >= self.dead_phi)

    def earliest_silent(self) -> float:
        """A time before which no SDC alive now can be :meth:`silent` (its silence must reach
        ``sdc_dead_s`` first; a heartbeat only moves it later)."""
        return min((t.t_last + self.sdc_dead_s for sdc, t in self.tracks.items()
                    if t.t_last is not None and sdc not in self.dead), default=float("inf"))

    def declare_dead(self, sdc: str) -> None:
        self.dead.add(sdc)
        self.tracks.setdefault(sdc, HeartbeatTrack()).since_dead = 0

    def summary(self, now: float) -> dict:
        out = {}
        for sdc, t in sorted(self.tracks.items()):
            mean, sigma = self._fit(t)
            out[sdc] = {"mean_interval_ms": round(mean * 1e3, 3), "sigma_ms": round(sigma * 1e3, 3),
                        "phi": round(self.phi(sdc, now), 2), "restarts": t.restarts, "dead": sdc in self.dead}
        return out
