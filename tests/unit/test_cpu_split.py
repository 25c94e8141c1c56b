"""The CPU split's plan (host_tools/cpu_split.py): which CPUs Open vSwitch gets and which the run."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from host_tools.cpu_split import plan


def test_two_cpus_give_the_switch_the_second_and_the_run_the_first():
    assert plan({0, 1}) == ([1], [0])


def test_one_cpu_is_not_split():
    assert plan({3}) is None


def test_the_switch_gets_the_highest_allowed_cpu_even_with_gaps():
    assert plan({5, 0, 2}) == ([5], [0, 2])


@given(st.sets(st.integers(0, 255), min_size=2, max_size=64))
def test_every_allowed_cpu_goes_to_exactly_one_side(allowed):
    switch, run = plan(allowed)
    assert set(switch) | set(run) == allowed and not set(switch) & set(run)
    assert switch and run
