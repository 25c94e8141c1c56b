"""AK bookkeeping and the dynamic-routing event ``DR_i = ViSC_WT_i ∧ ¬AK_i`` with its hold time.

Pure: every call takes ``now`` (s). A turbine's AK message says whether control packets arrive
normally (``ak``) and how long ago the last one arrived (``ctrl_age``), as of the moment it was
sent (``sent``, the GTNET header's timestamp: one clock on this testbed; the receive time where
the header is missing or implausible). The loss therefore started at ``sent − ctrl_age``.

``DR_i`` is confirmed from the turbine's own reports, not from the network's delays:

* **reported**: an AK = 0 whose ``ctrl_age`` shows the loss has lasted ``hold_s`` (the paper's
  40 ms) when it was sent. A delayed AK cannot cause it, and an AK = 1 that is still in flight
  cannot be overtaken by it: the turbine said so itself.
* **inferred from silence** (the failure also cut the AK path): no AK at all for ``ak_timeout_s``
  counts as AK = 0 from the last report on, confirmed after ``hold_s`` — but only while the
  controller is not stalled (``stalled``: no packet-in from any other source either; then the
  silence says nothing about this turbine and nothing is decided until packets flow again), and
  counted from the end of the last such stall (``resumed``) if that is later.

After a reroute the hold starts again when the new path can first deliver: every switch of it has
acknowledged its flows (barrier replies, :meth:`DrMonitor.path_ready`) plus the turbine's measured
one-way delay (its AKs' send stamps) — at the latest :data:`READY_TIMEOUT_S` after the reroute if
replies never come. So a loaded machine that takes 35 ms to install a path does not get a second
DR for the same failure, and a second failure on the new path is detected the same way — but a DR that did not bring the control packets back (they are still
missing when the next one is due) doubles the hold of the next (:meth:`DrMonitor.hold_of`): the loss is
then not the path's, and rerouting every 40 ms forever would only churn the switches.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from sdn_app.ak_streams import ACCEPTED, STALE_S, AkStreams

MAX_BACKOFF_DOUBLINGS = 5
READY_TIMEOUT_S = 0.1
"""After a reroute, the hold waits at most this long for the new path's acknowledgements."""
ONE_WAY_WEIGHT = 0.2
"""Weight of the newest AK in the turbine's one-way delay estimate (exponential average)."""
AK_MAX_STEP = 100
"""AK counter steps accepted without confirmation (about 1 s of AKs, losses included)."""
PLAUSIBLE_CLOCK_S = 1.0
"""An AK's send time further than this from its receive time is not trusted (other clock)."""


@dataclass
class AckTrack:
    """Per-turbine AK state."""

    ak: int = 0
    seq: int = -1
    streams: AkStreams = field(default_factory=lambda: AkStreams(AK_MAX_STEP))
    verdict: str = ""  # what the stream guard said of the last AK (sdn_app.ak_streams)
    ctrl_rx: int = 0
    t_last_rx: float | None = None
    t_last_sent: float | None = None
    t_loss: float | None = None
    t_reported: float | None = None
    t_rearm: float = float("-inf")
    fired: bool = False
    streak: int = 0  # DRs in a row without control packets coming back in between
    confirmed: int = 0
    armed: bool = True
    awaiting_path: bool = False  # rerouted; the hold is armed when the new path can deliver
    t_started: float = float("-inf")  # the last (re)start: a loss before it never counts
    one_way_s: float = 0.0  # the turbine's AKs' one-way delay (exponential average)


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
        t = self.tracks.get(wt)
        if t is None:
            t = self.tracks[wt] = AckTrack(streams=AkStreams(
                AK_MAX_STEP, quiet_s=self.ak_timeout_s, stale_s=max(STALE_S, self.ak_timeout_s)))
        return t

    def start(self, wt: str, now: float, *, armed: bool = True, await_path: bool = False) -> None:
        """A turbine was (re)routed at ``now``: a loss before ``now`` no longer counts.

        ``armed=False`` for a fresh ViSC start: until the first AK = 1 (communication established)
        the loss counts only from ``start_grace_s`` after the start, so the SDC's and the
        turbine's start-up is not mistaken for a failure. ``await_path`` after a reroute: the loss
        counts from :meth:`path_ready` (at the latest :data:`READY_TIMEOUT_S` from now); without
        it the hold restarts at once.
        """
        t = self.track(wt)
        t.t_loss, t.t_reported, t.fired, t.t_rearm, t.t_last_rx, t.t_last_sent = None, None, False, now, now, now
        t.t_started = now
        t.armed = armed
        t.awaiting_path = await_path and armed
        if not armed:
            t.t_rearm = now + self.start_grace_s
        elif await_path:
            t.t_rearm = now + READY_TIMEOUT_S

    def path_ready(self, wt: str, now: float) -> None:
        """Every switch of the turbine's new path acknowledged its flows at ``now``: the hold is
        armed from when a packet sent now can have arrived (``now`` + the measured one-way delay)."""
        t = self.tracks.get(wt)
        if t is not None and t.awaiting_path:
            t.awaiting_path = False
            t.t_rearm = min(t.t_rearm, now + t.one_way_s)
            if t.t_last_rx is not None:
                t.t_last_rx = max(t.t_last_rx, t.t_rearm)

    def stop(self, wt: str) -> None:
        self.tracks.pop(wt, None)

    def on_ak(self, wt: str, seq: int, ak: int, ctrl_rx: int, ctrl_age_s: float, now: float,
              sent: float | None = None) -> bool:
        """Record one AK message received at ``now`` (sent at ``sent``, if known); False if it is
        a duplicate, older than the last one, or not of the AK stream the app follows
        (:class:`sdn_app.ak_streams.AkStreams`; the verdict is left in the track's ``verdict``)."""
        t = self.track(wt)
        t.verdict = t.streams.admit(seq, ctrl_rx, now)
        if t.verdict not in ACCEPTED:
            return False  # duplicate, older, or another stream (forged, or not yet confirmed)
        if sent is None or not now - PLAUSIBLE_CLOCK_S <= sent <= now:
            sent = now
        else:
            t.one_way_s += ONE_WAY_WEIGHT * ((now - sent) - t.one_way_s)
        t.seq, t.ak, t.ctrl_rx, t.t_last_rx = seq, ak, ctrl_rx, now
        t.t_last_sent = sent if t.t_last_sent is None else max(t.t_last_sent, sent)
        if ak:
            if not t.armed:  # communication established: the start-up grace ends now
                t.armed, t.t_rearm = True, now
            t.t_loss, t.t_reported, t.fired, t.streak = None, None, False, 0
        else:
            started = max(sent - max(ctrl_age_s, 0.0), t.t_rearm)
            if t.t_loss is None or (t.t_reported is not None and started > t.t_reported):
                t.t_loss = started  # a new loss: control packets arrived after the previous report
            else:
                t.t_loss = min(t.t_loss, started)
            t.t_reported = sent if t.t_reported is None else max(t.t_reported, sent)
        return True

    def _silent(self, t: AckTrack, now: float, resumed: float) -> bool:
        return t.t_last_rx is not None and now - max(t.t_last_rx, resumed) > self.ak_timeout_s

    def loss_since(self, wt: str, now: float, *, stalled: bool = False,
                   resumed: float = float("-inf")) -> float | None:
        """When the current loss of control packets started (reported, or inferred from AK
        silence unless ``stalled``; silence counted from ``resumed``, the end of the controller's
        last stall, if later), or None if there is none."""
        t = self.tracks.get(wt)
        if t is None or now < t.t_rearm:
            return None
        if t.t_loss is not None:
            return t.t_loss
        if self._silent(t, now, resumed) and not stalled:
            return max(t.t_last_sent if t.t_last_sent is not None else t.t_last_rx, t.t_rearm)
        return None

    def reported_loss(self, wt: str) -> float:
        """How long the turbine's own reports say its current loss has lasted (0 if none)."""
        t = self.tracks.get(wt)
        if t is None or t.t_loss is None or t.t_reported is None:
            return 0.0
        return max(0.0, t.t_reported - t.t_loss)

    def hold_of(self, wt: str) -> float:
        """The hold for the turbine's next DR: ``hold_s``, doubled for every DR in a row that did
        not bring its control packets back (a reroute cannot cure a loss that is not the path's;
        at most 32 × ``hold_s``)."""
        t = self.tracks.get(wt)
        return self.hold_s * 2 ** min(t.streak if t else 0, MAX_BACKOFF_DOUBLINGS)

    def _confirmed(self, t: AckTrack, since: float, now: float, stalled: bool, resumed: float) -> bool:
        hold = self.hold_s * 2 ** min(t.streak, MAX_BACKOFF_DOUBLINGS)
        if t.t_reported is not None and t.t_reported - since >= hold:
            return True  # the turbine itself reported a loss as long as the hold
        return self._silent(t, now, resumed) and not stalled and now - since >= hold

    def earliest_due(self, wts, now: float) -> float:
        """A time before which :meth:`due` confirms none of ``wts`` unless an AK arrives first
        (an AK = 0 makes the controller decide at once): ``now`` while one has a loss in progress
        or awaits its new path, else the earliest moment one's AK silence can exceed
        ``ak_timeout_s`` (a confirmation by silence needs it; the hold only comes later)."""
        earliest = float("inf")
        for wt in wts:
            t = self.tracks.get(wt)
            if t is None or t.fired or t.t_last_rx is None:
                continue  # no AK yet, or its loss already confirmed: only an AK changes that
            if t.t_loss is not None or t.awaiting_path:
                return now
            earliest = min(earliest, max(t.t_rearm, t.t_last_rx + self.ak_timeout_s))
        return earliest

    def due(self, wt_in_visc: list[str], now: float, *, stalled: bool = False,
            resumed: float = float("-inf")) -> list[tuple[str, float]]:
        """Turbines whose DR is confirmed at ``now`` (each reported once per loss)."""
        out = []
        for wt in wt_in_visc:
            t = self.track(wt)
            since = self.loss_since(wt, now, stalled=stalled, resumed=resumed)
            if since is None or t.fired or since < t.t_started:
                continue  # (a loss dated before the last (re)start belongs to the path before it)
            if self._confirmed(t, since, now, stalled, resumed):
                t.fired = True
                t.streak += 1
                t.confirmed += 1
                out.append((wt, since))
        return out
