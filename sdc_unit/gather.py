"""Gathering one sample's measurements into one round.

The plant sends every turbine's ``MEAS`` of a sample together, but they reach the SDC one by one
(each through its own path of switches). A service that steps its controllers on every wake-up pays
the round's fixed cost (Python, numpy calls on cold caches, the socket calls) once per turbine;
one that waits a little after the first datagram of a sample answers them all in one round.

:func:`gather` waits — at most ``window_s`` wall seconds after the first datagram — until as many
measurements as the service expects (one per served turbine) have arrived, and returns everything
read, each datagram with the time it was read. A window of 0 returns what was read at once (every
wake-up is a round). What the wait costs is bounded by the window and paid only when a turbine's
measurement is late or lost: when all arrive, the round starts with the last of them.

Pure: the reading, waiting and clock are passed in (tests drive it with a manual clock).
"""

from __future__ import annotations

import time
from collections.abc import Callable

Datagram = tuple[bytes, tuple]


def gather(first: list[Datagram], first_read_at: float, read_more: Callable[[float], list[Datagram]],
           is_meas: Callable[[bytes], bool], expected: int, window_s: float,
           monotonic: Callable[[], float] = time.monotonic,
           now: Callable[[], float] | None = None) -> tuple[list[Datagram], list[float], bool]:
    """Datagrams of one round, for each when it was read (``now()``'s reading; ``first`` was read at
    ``first_read_at``), and whether the sample was complete (False: the window ran out first).

    ``read_more(timeout_s)`` waits up to ``timeout_s`` wall seconds for the socket to be readable
    and returns what is waiting (possibly nothing). ``expected``: measurements that make a complete
    sample (served turbines); the wait ends as soon as that many have been read, at the window's
    end, or at once when ``window_s`` ≤ 0 or nothing was read."""
    datagrams = list(first)
    read_at = [first_read_at] * len(datagrams)
    if window_s <= 0 or not datagrams:
        return datagrams, read_at, True
    count = sum(1 for data, _ in datagrams if is_meas(data))
    if count == 0:
        return datagrams, read_at, True  # commands only: carried out at once
    deadline = monotonic() + window_s
    clock = now or monotonic
    while count < expected:
        left = deadline - monotonic()
        if left <= 0:
            break
        more = read_more(left)
        if more:
            t = clock()
            datagrams += more
            read_at += [t] * len(more)
            count += sum(1 for data, _ in more if is_meas(data))
    return datagrams, read_at, count >= expected
