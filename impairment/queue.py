"""Link impairments as pure logic: what an impairment is, the timed queue that applies it to one
direction of a link, and the statistics an impairment element keeps (no sockets, no clock of its own).

A link's :class:`Impairment` is a one-way delay with uniform jitter (``delay ± jitter``, netem's
distribution without a table; never below zero), a Bernoulli loss probability and an optional
bandwidth. :class:`TimedQueue` is one direction of the link: a frame offered at ``t`` is lost with
probability ``loss`` (seeded numpy generator), otherwise it leaves no earlier than
``t + delay + jitter draw`` and never before the frame ahead of it (a link does not reorder:
release times are clamped to be non-decreasing). Times are the caller's clock's seconds (the run's
simulated seconds, :mod:`sdvisc.clock`), so delays scale with virtual time. Bandwidth is not
applied here (the element puts a TBF qdisc on its egress, :mod:`impairment.element`).
"""

from __future__ import annotations

from array import array
from collections import deque
from dataclasses import asdict, dataclass, replace
from statistics import NormalDist

import numpy as np
from pydantic import ValidationError

from sdvisc.config import LinkImpairmentOptions

DRAW_BATCH = 4096  # uniform draws fetched from the generator at once (a scalar draw per frame is slow)
KEYS = ("delay_ms", "jitter_ms", "loss", "bw_mbps")


@dataclass(frozen=True)
class Impairment:
    """What one link does to every frame, in both directions."""

    delay_ms: float = 0.0
    jitter_ms: float = 0.0
    loss: float = 0.0
    bw_mbps: float | None = None

    def __post_init__(self) -> None:
        """The bounds of a scenario's ``links`` entries (:class:`sdvisc.config.LinkImpairmentOptions`,
        defined once there): an impairment set at run time (the CLI's ``impair``) obeys the same."""
        try:
            LinkImpairmentOptions(**asdict(self))
        except ValidationError as exc:
            problems = "; ".join(f"{'.'.join(map(str, e['loc']))}: {e['msg']}, got {e.get('input')!r}"
                                 for e in exc.errors())
            raise ValueError(problems) from None

    @classmethod
    def of(cls, options: LinkImpairmentOptions) -> Impairment:
        """The impairment of a scenario's ``links`` entry (its seed is the queue's, not the impairment's)."""
        return cls(**{key: getattr(options, key) for key in KEYS})

    @property
    def delay_s(self) -> float:
        return self.delay_ms / 1e3

    @property
    def jitter_s(self) -> float:
        return self.jitter_ms / 1e3

    @property
    def clear(self) -> bool:
        return self == Impairment()

    def merged(self, **changes) -> Impairment:
        """This impairment with the given keys changed (``None`` values are ignored, except
        ``bw_mbps=0`` which removes the bandwidth limit)."""
        given = {k: v for k, v in changes.items() if v is not None}
        unknown = set(given) - set(KEYS)
        if unknown:
            raise ValueError(f"unknown impairment keys {sorted(unknown)}; known: {', '.join(KEYS)}")
        if given.get("bw_mbps") == 0:
            given["bw_mbps"] = None
        return replace(self, **given)

    def as_dict(self) -> dict:
        return asdict(self)

    def describe(self) -> str:
        """``delay=5ms jitter=0.5ms loss=1% bw=100Mbit/s`` (only what is set), or ``clear``."""
        parts = []
        if self.delay_ms:
            parts.append(f"delay={self.delay_ms:g}ms")
        if self.jitter_ms:
            parts.append(f"jitter={self.jitter_ms:g}ms")
        if self.loss:
            parts.append(f"loss={self.loss * 100:g}%")
        if self.bw_mbps is not None:
            parts.append(f"bw={self.bw_mbps:g}Mbit/s")
        return " ".join(parts) or "clear"


class Uniforms:
    """Uniform [0, 1) draws from a seeded numpy generator, fetched in batches."""

    def __init__(self, rng: np.random.Generator, batch: int = DRAW_BATCH) -> None:
        self.rng = rng
        self.batch = batch
        self._values: list[float] = []
        self._next = 0

    def __call__(self) -> float:
        if self._next >= len(self._values):
            self._values = self.rng.random(self.batch).tolist()
            self._next = 0
        value = self._values[self._next]
        self._next += 1
        return value


class TimedQueue:
    """One direction of an impaired link (see the module docstring).

    ``offer(frame, t)`` returns False for a lost frame; ``next_release()`` is the time the head
    frame is due (None if empty); ``pop_due(now)`` yields ``(frame, t_arrival, t_release)`` of
    every frame due at ``now``, in order.
    """

    def __init__(self, impairment: Impairment, rng: np.random.Generator) -> None:
        self.impairment = impairment
        self.uniform = Uniforms(rng)
        self.frames: deque[tuple[bytes, float, float]] = deque()
        self.last_release = float("-inf")

    def set(self, impairment: Impairment) -> None:
        """Use ``impairment`` for frames offered from now on (frames queued keep their times)."""
        self.impairment = impairment

    def offer(self, frame: bytes, t_arrival: float) -> bool:
        imp = self.impairment
        if imp.loss and self.uniform() < imp.loss:
            return False
        delay = imp.delay_s
        if imp.jitter_ms:
            delay = max(0.0, delay + imp.jitter_s * (2.0 * self.uniform() - 1.0))
        release = t_arrival + delay
        if release < self.last_release:
            release = self.last_release
        self.last_release = release
        self.frames.append((frame, t_arrival, release))
        return True

    def next_release(self) -> float | None:
        return self.frames[0][2] if self.frames else None

    def pop_due(self, now: float):
        frames = self.frames
        while frames and frames[0][2] <= now:
            yield frames.popleft()

    def drop_all(self) -> int:
        """Forget every queued frame (e.g. the link went down); returns how many."""
        n = len(self.frames)
        self.frames.clear()
        return n

    def __len__(self) -> int:
        return len(self.frames)


def percentiles_ms(samples_s, qs=(50, 95)) -> dict:
    """``{"p50": …, "p95": …, "max": …, "n": …}`` of ``samples_s`` (seconds) in ms (None if empty)."""
    values = np.frombuffer(samples_s, dtype=np.float64) if isinstance(samples_s, array) else np.asarray(samples_s)
    if values.size == 0:
        return {**{f"p{q}": None for q in qs}, "max": None, "n": 0}
    out = {f"p{q}": round(float(v) * 1e3, 4) for q, v in zip(qs, np.percentile(values, qs))}
    return {**out, "max": round(float(values.max()) * 1e3, 4), "n": int(values.size)}


class Phase:
    """What an element measured while one impairment was configured (from ``t_from``)."""

    COUNTERS = ("offered", "forwarded", "dropped_loss", "dropped_queue", "dropped_link_down")

    def __init__(self, impairment: Impairment, t_from: float, directions: tuple[str, str],
                 max_samples: int = 2_000_000) -> None:
        self.impairment = impairment
        self.t_from = t_from
        self.t_to: float | None = None
        self.counts = {d: dict.fromkeys(self.COUNTERS, 0) for d in directions}
        self.added_s = array("d")  # departure − arrival, per forwarded frame
        self.late_s = array("d")  # departure − planned release (the element's own timing error)
        self.max_samples = max_samples

    def sent(self, direction: str, added_s: float, late_s: float) -> None:
        self.counts[direction]["forwarded"] += 1
        if len(self.added_s) < self.max_samples:
            self.added_s.append(added_s)
            self.late_s.append(late_s)

    def totals(self) -> dict:
        return {k: sum(c[k] for c in self.counts.values()) for k in self.COUNTERS}

    def report(self, with_percentiles: bool) -> dict:
        """JSON-ready: configured values, counters per direction and in total, and (at the end of
        the phase) the added delay and the timing error (departure − planned) in ms."""
        totals = self.totals()
        offered = totals["offered"]
        out = {"t_from": self.t_from, "t_to": self.t_to, "configured": self.impairment.as_dict(),
               "directions": self.counts, **totals,
               "loss_rate": round(totals["dropped_loss"] / offered, 6) if offered else None}
        if with_percentiles:
            added = percentiles_ms(self.added_s)
            out["added_delay_ms"] = added
            out["added_delay_error_ms"] = {k: (round(v - self.impairment.delay_ms, 4) if v is not None else None)
                                           for k, v in added.items() if k != "n"}
            out["late_ms"] = percentiles_ms(self.late_s)
        return out


def binomial_interval(n: int, p: float, confidence: float = 0.99) -> tuple[float, float]:
    """The central ``confidence`` interval of the fraction k/n for k ~ Binomial(n, p) (normal
    approximation with continuity correction; fine for n·p·(1−p) ≥ 10)."""
    if n <= 0:
        return (0.0, 1.0)
    z = NormalDist().inv_cdf(0.5 + confidence / 2)
    half = z * (p * (1 - p) / n) ** 0.5 + 0.5 / n
    return (max(0.0, p - half), min(1.0, p + half))
