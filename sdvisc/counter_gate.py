"""A sender's message counter that one forged or mutated datagram cannot take over.

Receivers order a sender's messages by its counter (``seq``) and drop what is not newer. Taken
naively, one datagram with ``seq = 2**31 - 1`` makes every later genuine message "old" and the
receiver stops listening to the sender for good. A :class:`CounterGate` accepts a counter only
while it moves forward by a plausible step (``max_step``: losses included); a jump — forward by
more, or backward, as when the sender restarts — is accepted once a second message confirms it
(continues from it within ``confirm_window``). While forged and genuine messages interleave,
neither stream can be confirmed against the other for long; once the forgeries stop, the genuine
counter is followed again after at most two messages.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

Verdict = Literal["ok", "resync", "stale", "jump"]


@dataclass
class CounterGate:
    """See the module docstring. :meth:`admit` returns ``"ok"`` or ``"resync"`` (accepted: the
    message is to be used) or ``"stale"`` / ``"jump"`` (dropped)."""

    max_step: int
    confirm_window: int = 3
    last: int | None = None
    candidate: int | None = None

    def __post_init__(self) -> None:
        if self.max_step < 1 or self.confirm_window < 1:
            raise ValueError("max_step and confirm_window must be at least 1")

    def admit(self, seq: int) -> Verdict:
        if self.last is None or self.last < seq <= self.last + self.max_step:
            self.last, self.candidate = seq, None
            return "ok"
        if self.candidate is not None and self.candidate < seq <= self.candidate + self.confirm_window:
            self.last, self.candidate = seq, None
            return "resync"
        self.candidate = seq
        return "stale" if seq <= self.last else "jump"

    def accepts(self, verdict: Verdict) -> bool:
        return verdict in ("ok", "resync")
