"""Reading a process's CPU time from /proc (sdvisc.netns: the runner, the calibration, a server's
processes over ssh and the benchmarks use the one parser)."""

from __future__ import annotations

import os
import time

import pytest

from sdvisc.netns import CLOCK_TICKS, cpu_seconds_of, stat_cpu_seconds


def test_utime_and_stime_are_read_after_the_command_name_even_with_parentheses_in_it():
    fields = ["S"] + ["0"] * 10 + ["250", "50"] + ["0"] * 30  # state, ..., utime (14), stime (15)
    text = f"4242 (evil) name (x)) {' '.join(fields)}\n"
    assert stat_cpu_seconds(text) == pytest.approx(300 / CLOCK_TICKS)


@pytest.mark.parametrize("text", ["", "4242 (gone", "no parenthesis here"])
def test_what_is_not_a_stat_line_is_refused(text):
    with pytest.raises(ValueError):
        stat_cpu_seconds(text)


def test_this_process_counts_the_cpu_it_burns_and_a_gone_one_is_none():
    before = cpu_seconds_of(os.getpid())
    end = time.process_time() + 0.2
    while time.process_time() < end:
        pass
    assert cpu_seconds_of(os.getpid()) - before >= 0.1
    assert cpu_seconds_of(2**22 + 12345) is None
