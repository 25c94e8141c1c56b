"""Which AK stream of a turbine the SDN app believes: pure, ``now`` passed in.

A turbine's AKs form one *stream*: the AK counter ``seq`` moves forward by small steps (losses
included) and ``ctrl_rx`` (control packets the turbine has received) never goes back. Behind a
plain L2 switch another host can send AKs with the turbine's own IP and MAC (docs/sdn.md); the
app cannot tell the datagrams apart, but it can tell the *streams* apart:

* a message that continues the stream the app follows (``seq`` ahead by at most ``max_step``,
  ``ctrl_rx`` not lower than the lower of its last two messages') is used (``"ok"``); one a little behind it (a reordered or duplicated
  genuine AK: ``seq`` and ``ctrl_rx`` both not newer) is dropped as ``"stale"``;
* anything else starts or continues a *candidate* stream (at most :data:`MAX_CANDIDATES` kept).
  A candidate replaces the followed stream only **once the followed stream has stopped**: it sent
  nothing for ``stale_s`` (:data:`STALE_S`, far beyond the 40 ms DR hold, so a loss that silences
  the genuine AKs is a DR before anything else could be followed) and the candidate is alive and
  was continued at least once (``"adopted"``): a restarted turbine, the same turbine after an
  outage longer than ``max_step`` AKs — or the genuine stream again, if a gap let another one be
  followed for a while. The stream that was followed stays a candidate (it may come back);
* two streams alive together (a candidate continued at least once, and the followed stream sent
  a message after the candidate began) are a **conflict**: reported once per episode
  (:meth:`AkStreams.take_conflict`; the episode ends when the candidate has been silent for
  ``quiet_s``), its messages dropped (``"rejected"``).

So a forged stream that runs beside the genuine one changes nothing the app decides: no DR, no
T3 change — and a real loss on the genuine stream is still seen, from its own AK = 0 reports or
from its silence (:mod:`sdn_app.dr`). What this cannot do: tell which stream is genuine when the
forger was first (before the turbine's first AK), or reject a forger who sees the genuine AKs and
continues them (docs/sdn.md).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

Verdict = Literal["ok", "adopted", "stale", "candidate", "rejected"]
ACCEPTED = ("ok", "adopted")
MAX_CANDIDATES = 4
"""Candidate streams kept per turbine (the stalest is forgotten first)."""
STALE_S = 0.5
"""Silence after which the followed stream has stopped and a live candidate may replace it."""


@dataclass
class Stream:
    """One sequence of AKs: its newest counter values and when it was first and last seen."""

    seq: int
    ctrl_rx: int
    t_first: float
    t_last: float
    n: int = 1
    ctrl_before: int | None = None  # the ctrl_rx of the message before the last

    def continued_by(self, seq: int, ctrl_rx: int, max_step: int) -> bool:
        """``seq`` a little ahead, ``ctrl_rx`` not below the lower of the last two messages' (one
        message with a mutated, huge ``ctrl_rx`` cannot make every later genuine one "go back")."""
        floor = self.ctrl_rx if self.ctrl_before is None else min(self.ctrl_rx, self.ctrl_before)
        return self.seq < seq <= self.seq + max_step and ctrl_rx >= floor

    def take(self, seq: int, ctrl_rx: int, now: float) -> None:
        self.ctrl_before = self.ctrl_rx
        self.seq, self.ctrl_rx, self.t_last, self.n = seq, ctrl_rx, max(self.t_last, now), self.n + 1


@dataclass
class AkStreams:
    """The AK streams of one turbine (see the module docstring)."""

    max_step: int = 100
    quiet_s: float = 0.030
    stale_s: float = STALE_S
    confirm: int = 2
    current: Stream | None = None
    candidates: list[Stream] = field(default_factory=list)
    conflicts: int = 0
    in_conflict: bool = False
    new_conflict: dict | None = None

    def __post_init__(self) -> None:
        if self.max_step < 1 or not 0 < self.quiet_s <= self.stale_s or self.confirm < 2:
            raise ValueError("max_step must be at least 1, 0 < quiet_s <= stale_s, confirm at least 2")

    def admit(self, seq: int, ctrl_rx: int, now: float) -> Verdict:
        """Classify one AK (``seq``, ``ctrl_rx``) received at ``now``."""
        cur = self.current
        if cur is None:
            self.current = Stream(seq, ctrl_rx, now, now)
            return "ok"
        if cur.continued_by(seq, ctrl_rx, self.max_step):
            cur.take(seq, ctrl_rx, now)
            self._end_episode(now)
            self._live_conflict(now)
            return "ok"
        if cur.seq - self.max_step < seq <= cur.seq and ctrl_rx <= cur.ctrl_rx:
            return "stale"
        cand = next((c for c in self.candidates if c.continued_by(seq, ctrl_rx, self.max_step)), None)
        if cand is None:
            cand = Stream(seq, ctrl_rx, now, now)
            self.candidates.append(cand)
            self.candidates.sort(key=lambda c: c.t_last)
            del self.candidates[:-MAX_CANDIDATES]
            return "candidate"
        cand.take(seq, ctrl_rx, now)
        if cand.n >= self.confirm and now - cur.t_last >= self.stale_s:
            self.current, self.candidates = cand, [c for c in self.candidates if c is not cand] + [cur]
            self.in_conflict = False
            return "adopted"
        self._live_conflict(now)
        return "rejected" if cand.n >= self.confirm else "candidate"

    def take_conflict(self) -> dict | None:
        """The conflict episode that began with the last message (once), or None."""
        out, self.new_conflict = self.new_conflict, None
        return out

    def _live_conflict(self, now: float) -> None:
        """Start a conflict episode (counted once) if a continued candidate began before the
        followed stream's last message and is itself still alive."""
        if self.in_conflict:
            return
        cur = self.current
        for c in self.candidates:
            if c.n >= self.confirm and c.t_first <= cur.t_last and now - c.t_last < self.quiet_s:
                self.in_conflict = True
                self.conflicts += 1
                self.new_conflict = {"followed_seq": cur.seq, "followed_ctrl_rx": cur.ctrl_rx,
                                     "other_seq": c.seq, "other_ctrl_rx": c.ctrl_rx}
                return

    def _end_episode(self, now: float) -> None:
        """The episode ends once no continued candidate has been heard for ``quiet_s``."""
        if self.in_conflict and not any(c.n >= self.confirm and now - c.t_last < self.quiet_s
                                        for c in self.candidates):
            self.in_conflict = False
