"""AK bookkeeping and the dynamic-routing event ``DR_i = ViSC_WT_i ∧ ¬AK_i`` with its hold time.

Pure: every call takes ``now`` (s). A turbine's AK message says whether control packets arrive
normally (``ak``) and how long ago the last one arrived (``ctrl_age``); the loss therefore
started at ``t_rx − ctrl_age``. A missing AK counts as 0: if no AK has arrived for
``ak_timeout_s`` the loss is taken to have started at the last AK received. ``DR_i`` is confirmed
once the loss has lasted ``hold_s`` (the paper's 40 ms), checked on every timer tick. After a
reroute the hold starts again from the reroute time, so a second failure on the new path is
detected the same way.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class AckTrack:
    """Per-turbine AK state."""

    ak: int = 0
    seq: int = -1
    ctrl_rx: int = 0
    t_last_rx: float | None = None
    t_loss: float | None = None
    t_rearm: float = float("-inf")
    fired: bool = False
    confirmed: int = 0
    armed: bool = True


class DrMonitor:
    """Tracks AK per turbine and reports confirmed DR events."""

    def __init__(self, hold_s: float = 0.040, ak_timeout_s: float = 0.030, start_grace_s: float = 0.5) -> None:
        if hold_s <= 0 or ak_timeout_s <= 0 or start_grace_s < 0:
            raise ValueError("hold_s and ak_timeout_s must be positive, start_grace_s not negative")
        self.hold_s = hold_s
        self.ak_timeout_s = ak_timeout_s
        self.start_grace_s = start_grace_s
        self.tracks: dict[str, AckTrack] = {}

    def track(self, wt: str) -> AckTrack:
        return self.tracks.setdefault(wt, AckTrack())

    def start(self, wt: str, now: float, *, armed: bool = True) -> None:
        """A turbine was (re)routed at ``now``: a loss before ``now`` no longer counts.

        ``armed=False`` for a fresh ViSC start: until the first AK = 1 (communication established)
        the loss counts only from ``start_grace_s`` after the start, so the SDC's and the
        turbine's start-up is not mistaken for a failure; after a reroute the hold restarts at once.
        """
        t = self.track(wt)
        t.t_loss, t.fired, t.t_rearm, t.t_last_rx = None, False, now, now
        t.armed = armed
        if not armed:
            t.t_rearm = now + self.start_grace_s

    def stop(self, wt: str) -> None:
        self.tracks.pop(wt, None)

    def on_ak(self, wt: str, seq: int, ak: int, ctrl_rx: int, ctrl_age_s: float, now: float) -> bool:
        """Record one AK message; False if it is a duplicate or older than the last one."""
        t = self.track(wt)
        if seq <= t.seq:
            return False
        t.seq, t.ak, t.ctrl_rx, t.t_last_rx = seq, ak, ctrl_rx, now
        if ak:
            if not t.armed:  # communication established: the start-up grace ends now
                t.armed, t.t_rearm = True, now
            t.t_loss, t.fired = None, False
        else:
            started = max(now - max(ctrl_age_s, 0.0), t.t_rearm)
            t.t_loss = started if t.t_loss is None else min(t.t_loss, started)
        return True

    def loss_since(self, wt: str, now: float) -> float | None:
        """When the current loss of control packets started, or None if there is none."""
        t = self.tracks.get(wt)
        if t is None:
            return None
        if t.t_loss is not None:
            return t.t_loss if now >= t.t_rearm else None
        if t.t_last_rx is not None and now - t.t_last_rx > self.ak_timeout_s and now >= t.t_rearm:
            return max(t.t_last_rx, t.t_rearm)  # AK messages stopped: missing AK counts as 0
        return None

    def due(self, wt_in_visc: list[str], now: float) -> list[tuple[str, float]]:
        """Turbines whose DR is confirmed at ``now`` (each reported once per loss)."""
        out = []
        for wt in wt_in_visc:
            t = self.track(wt)
            since = self.loss_since(wt, now)
            if since is None or t.fired:
                continue
            if now - since >= self.hold_s:
                t.fired = True
                t.confirmed += 1
                out.append((wt, since))
        return out
