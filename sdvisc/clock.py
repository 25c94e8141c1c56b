"""The testbed's one clock: every component reads time and sleeps through it.

``time_scale`` is k wall seconds per simulated second (virtual time, as in time-dilation network
emulators): with k > 1 every component of the project runs k times slower than the wall clock,
while Open vSwitch and the kernel do not, so the emulated network looks k times faster and the
plant gets k times more wall time per step. k = 1 is real time.

:meth:`Clock.now` is a *virtual wall clock*: seconds since the Unix epoch, but advancing at 1/k of
the real rate from a shared ``epoch`` (a wall time all processes of a run agree on), so that
timestamps written by one process (GTNET headers, events) and read by another compare directly,
and every difference of two readings is in simulated seconds. :meth:`Clock.sleep` sleeps
``dt`` simulated seconds (k·dt of wall time). Tests inject a :class:`ManualClock`, or give a
:class:`Clock` a wall clock of their own (``wall`` and ``wall_sleep``: by default the real
``time.time`` and ``time.sleep``).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Clock:
    """Scaled wall clock (see the module docstring)."""

    time_scale: float = 1.0
    epoch: float = 0.0
    wall: Callable[[], float] = field(default=time.time, repr=False, compare=False)
    wall_sleep: Callable[[float], None] = field(default=time.sleep, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not self.time_scale >= 1.0:
            raise ValueError(f"time_scale must be >= 1 (wall seconds per simulated second), got {self.time_scale}")

    def now(self) -> float:
        """Virtual seconds since the Unix epoch (equal to the wall clock at ``epoch``)."""
        wall = self.wall()
        return self.epoch + (wall - self.epoch) / self.time_scale if self.time_scale != 1.0 else wall

    def to_wall(self, t: float) -> float:
        """The wall time at which this clock reads ``t``."""
        return self.epoch + (t - self.epoch) * self.time_scale

    def from_wall(self, wall: float) -> float:
        """This clock's reading at wall time ``wall``."""
        return self.epoch + (wall - self.epoch) / self.time_scale

    def sleep(self, dt: float) -> None:
        """Sleep ``dt`` simulated seconds."""
        if dt > 0:
            self.wall_sleep(dt * self.time_scale)

    def sleep_until(self, t: float) -> float:
        """Sleep until this clock reads ``t`` (at once if it already does); returns :meth:`now`."""
        wait = self.to_wall(t) - self.wall()
        if wait > 0:
            self.wall_sleep(wait)
        return self.now()

    def wall_s(self, dt: float) -> float:
        """Wall seconds that ``dt`` simulated seconds take."""
        return dt * self.time_scale


REAL_TIME = Clock()


class ManualClock:
    """A clock for tests: time moves only when told to (``advance``), sleeping advances it."""

    def __init__(self, t: float = 0.0, time_scale: float = 1.0) -> None:
        self.t = t
        self.time_scale = time_scale
        self.slept: list[float] = []

    def now(self) -> float:
        return self.t

    def advance(self, dt: float) -> None:
        self.t += dt

    def sleep(self, dt: float) -> None:
        if dt > 0:
            self.slept.append(dt)
            self.t += dt

    def sleep_until(self, t: float) -> float:
        self.sleep(t - self.t)
        return self.t

    def wall_s(self, dt: float) -> float:
        return dt * self.time_scale
