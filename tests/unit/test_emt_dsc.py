"""The EMT SDViSCs' positive-sequence measurement (plant/emt/frame.py: quarter-cycle delayed-signal
cancellation on the Park phasor) against the closed form: a three-phase set with a positive sequence V1, a
negative sequence V2 and a zero sequence V0 has the positive-sequence phasor V1.

Tolerances: after the filter's settling time T0/4 (5 ms) the output is V1 within 1e-3 p.u. (the rounding of
T0/4 to whole steps at h = Ts/13 leaves |V2| * w0 * 2 * 0.015 h / 2 ≈ 2.4e-4 |V2|); the streaming form
equals the array form to 1e-12; a balanced set passes unchanged from the first sample (1e-12)."""

from __future__ import annotations

import numpy as np
import pytest

from plant.emt import frame
from plant.emt.model import TS_S
from sdvisc.vocabulary import OMEGA0

H = TS_S / 13  # the EMT backend's circuit step
V1, V2, V0 = 0.62 * np.exp(0.3j), 0.25 * np.exp(-1.1j), 0.2 * np.exp(0.7j)  # an SLG-like unbalance [assumed]


def _abc(t: np.ndarray, v1: complex, v2: complex, v0: complex) -> np.ndarray:
    """Phase values (circuit units, frame's scaling) of sequence phasors on the 50 Hz carrier."""
    a = frame.A
    pos, neg = np.array([1.0, a * a, a]), np.array([1.0, a, a * a])
    rot = np.exp(1j * OMEGA0 * t)[:, None]
    return frame.PEAK_PER_PU * np.real(v1 * rot * pos + v2 * rot * neg + v0 * rot)


def test_delay_is_a_quarter_cycle():
    d = frame.dsc_delay_steps(H)
    assert d == 97
    assert abs(d * H - 0.005) < 0.02 * H


def test_unbalanced_set_gives_its_positive_sequence_after_a_quarter_cycle():
    t = np.arange(1, 2000) * H
    x = frame.park(_abc(t, V1, V2, V0), t)
    assert np.max(np.abs(x - V1)) == pytest.approx(abs(V2), rel=1e-9)  # the raw Park phasor: the 100 Hz ripple
    d = frame.dsc_delay_steps(H)
    y = frame.positive_sequence_dsc(x, d)
    assert np.max(np.abs(y[d:] - V1)) < 1e-3
    assert np.max(np.abs(y[d:] - V1)) < 3e-4 * abs(V2)  # closed form of the rounding's residue: 2.4e-4 abs(V2)


def test_balanced_set_passes_unchanged():
    t = np.arange(1, 500) * H
    x = frame.park(_abc(t, V1, 0j, 0j), t)
    y = frame.positive_sequence_dsc(x, frame.dsc_delay_steps(H))
    assert np.max(np.abs(y - V1)) < 1e-12


def test_step_to_an_unbalance_settles_within_a_quarter_cycle():
    """Balanced V1 until step 300, then V1' + V2: the output is V1' from step 300 + d on."""
    t = np.arange(1, 1200) * H
    v1b = 0.6 * np.exp(0.2j)
    abc = np.where((np.arange(len(t)) < 300)[:, None], _abc(t, V1, 0j, 0j), _abc(t, v1b, V2, V0))
    d = frame.dsc_delay_steps(H)
    y = frame.positive_sequence_dsc(frame.park(abc, t), d)
    assert np.max(np.abs(y[300 + d:] - v1b)) < 1e-3
    assert np.max(np.abs(y[:300] - V1)) < 1e-12


def test_streaming_form_equals_the_array_form():
    t = np.arange(1, 800) * H
    x = frame.park(_abc(t, V1, V2, V0), t)
    d = frame.dsc_delay_steps(H)
    f = frame.QuarterCycleDsc(d, x[0])
    y = np.array([f.push(k, complex(xk)) for k, xk in enumerate(x)])
    assert np.max(np.abs(y - frame.positive_sequence_dsc(x, d))) < 1e-12
    g = frame.QuarterCycleDsc(d, x[0])  # only the steps a sample every 13 needs are stored
    for k, xk in enumerate(x):
        if (k + 1) % 13 == 0:
            assert abs(g.push(k, complex(xk)) - y[k]) < 1e-12
        elif (k + 1 + d) % 13 == 0:
            g.store(k, complex(xk))
