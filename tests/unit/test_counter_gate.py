"""The counter gate: one forged counter cannot take a sender's stream over (pure)."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from sdvisc.counter_gate import CounterGate


def test_forward_steps_losses_and_duplicates():
    g = CounterGate(max_step=10)
    assert [g.admit(s) for s in (5, 6, 9, 19)] == ["ok"] * 4
    assert g.admit(19) == "stale" and g.admit(3) == "stale" and g.last == 19


def test_one_forged_counter_does_not_silence_the_sender():
    g = CounterGate(max_step=10)
    for s in range(1, 20):
        g.admit(s)
    assert g.admit(2**31 - 1) == "jump"
    assert g.admit(20) == "ok" and g.last == 20


def test_a_restart_is_followed_after_one_confirming_message():
    g = CounterGate(max_step=10)
    for s in range(100, 120):
        g.admit(s)
    assert g.admit(1) == "stale" and g.admit(2) == "resync" and g.last == 2


@given(forged=st.lists(st.integers(-2**31, 2**31 - 1), max_size=50), start=st.integers(0, 10**6))
def test_after_any_forgeries_the_genuine_stream_is_followed_within_two_messages(forged, start):
    g = CounterGate(max_step=100)
    g.admit(start)
    for f in forged:
        g.admit(f)
    genuine = start + 1000
    verdicts = [g.admit(genuine + k) for k in range(3)]
    assert g.accepts(verdicts[1]) and g.accepts(verdicts[2]) and g.last == genuine + 2
