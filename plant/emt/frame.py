"""Phase quantities of the EMT circuit <-> per-unit phasors in the common frame.

The circuit runs in per unit on the network base (500 MVA): base line-to-line RMS voltage 1 V, base
power 1 VA, so 1 ohm = 1 p.u. and a balanced 1 p.u. voltage is a phase peak of sqrt(2/3) V. DPsim's
three-phase sources take a complex phasor: ``VoltageSource.V_ref`` as line-to-line RMS (= our p.u.
phasor), ``CurrentSource.I_ref`` as phase RMS (= p.u. / sqrt(3)); measured with the probe of
tests/unit/test_emt_frame.py. The common frame rotates at omega0 = 2 pi 50 Hz from t = 0.
"""

from __future__ import annotations

import math

import numpy as np

from sdvisc.vocabulary import OMEGA0

A = np.exp(2j * np.pi / 3.0)
PEAK_PER_PU = np.sqrt(2.0 / 3.0)  # phase peak of a balanced 1 p.u. phasor
PHASE_RMS_PER_PU = 1.0 / np.sqrt(3.0)  # phase RMS of 1 p.u.


def park(abc: np.ndarray, t: np.ndarray | float) -> np.ndarray:
    """The space vector of phase values ``abc`` (last axis a, b, c; circuit units) in the common frame,
    scaled to a p.u. phasor: a balanced positive sequence of phasor V gives V; a negative sequence V2
    gives V2 e^{-j 2 omega0 t} (a ripple at 100 Hz); the zero sequence drops out."""
    abc = np.asarray(abc, dtype=float)
    space = (2.0 / 3.0) * (abc[..., 0] + A * abc[..., 1] + A * A * abc[..., 2])
    return space / PEAK_PER_PU * np.exp(-1j * OMEGA0 * np.asarray(t))


_K = 2.0 / 3.0 / PEAK_PER_PU
_S3 = np.sqrt(3.0) / 2.0


def park_sample(a: float, b: float, c: float, t: float) -> complex:
    """:func:`park` of one sample in plain Python (the stepped run's per-step measurement; ~10x cheaper
    than the numpy call on three numbers)."""
    re = a - 0.5 * (b + c)
    im = _S3 * (b - c)
    w = OMEGA0 * t
    co, si = math.cos(w), math.sin(w)
    return complex(_K * (re * co + im * si), _K * (im * co - re * si))


def positive_sequence(x_park: np.ndarray, samples_per_cycle: int) -> np.ndarray:
    """The positive-sequence phasor: the mean of the Park phasor over the last cycle (removes the
    negative sequence's 100 Hz ripple exactly in a steady state; 10 ms delay), same length as input."""
    c = np.cumsum(np.r_[0.0, x_park])
    n = samples_per_cycle
    out = np.empty(len(x_park), dtype=complex)
    k = np.arange(len(x_park))
    lo = np.maximum(k + 1 - n, 0)
    out[:] = (c[k + 1] - c[lo]) / (k + 1 - lo)
    return out


def phase_rms(abc: np.ndarray, samples_per_cycle: int) -> np.ndarray:
    """Per-phase RMS over the last cycle, in p.u. of the nominal phase RMS (rows as input)."""
    sq = np.cumsum(np.vstack([np.zeros((1, 3)), np.asarray(abc, dtype=float) ** 2]), axis=0)
    n = samples_per_cycle
    k = np.arange(len(abc))
    lo = np.maximum(k + 1 - n, 0)
    mean = (sq[k + 1] - sq[lo]) / (k + 1 - lo)[:, None]
    return np.sqrt(mean) / PHASE_RMS_PER_PU


def delta_side(abc: np.ndarray) -> np.ndarray:
    """Line quantities on the delta side of an ideal YNd step-up (per unit of the same base), from the
    star side's line quantities: x_A = (x_a - x_b)/sqrt(3), ... (the 30 degree shift, positive and
    negative sequence in opposite senses; no zero sequence passes)."""
    abc = np.asarray(abc, dtype=float)
    return (abc - np.roll(abc, -1, axis=-1)) / np.sqrt(3.0)


def phasor_to_abc(v: complex, t: np.ndarray | float) -> np.ndarray:
    """Instantaneous phase values (circuit units) of a balanced p.u. phasor ``v`` at ``t``."""
    rot = np.array([1.0, A * A, A])
    return PEAK_PER_PU * np.real(np.multiply.outer(v * np.exp(1j * OMEGA0 * np.asarray(t)), rot))


MEASUREMENTS = ("park", "dsc", "dsc_pq", "dsc_ipq")
"""What the SDViSCs' law is given (plant/emt/farm_run.py): ``park`` the raw Park phasor of each circuit step's
sample (negative sequence as a 100 Hz ripple), ``dsc`` its positive sequence by quarter-cycle delayed-signal
cancellation (:class:`QuarterCycleDsc`) for every input, ``dsc_pq`` the raw v, i with P + jQ of the positive
sequences, ``dsc_ipq`` the raw v with the current and P + jQ of the positive sequences."""


def dsc_delay_steps(h: float) -> int:
    """The quarter cycle T0/4 (5 ms at 50 Hz) in circuit steps of ``h`` (rounded: at h = Ts/13 = 51.54 µs it
    is 97.01 steps; the 0.015-step remainder leaves 2.4e-4 of a negative sequence, see
    :func:`positive_sequence_dsc`)."""
    return int(round(0.5 * math.pi / (OMEGA0 * h)))


def positive_sequence_dsc(x_park: np.ndarray, d: int) -> np.ndarray:
    """The positive sequence of Park phasors ``x_park`` (first axis: circuit steps) by delayed-signal
    cancellation over a quarter cycle: x1(t) = (x(t) + x(t - T0/4)) / 2 with ``d`` steps = T0/4.

    In the stationary frame this is the instantaneous symmetrical-components positive-sequence calculation
    v+ = (v + j q v)/2 with the quadrature signal q v taken as the quarter-cycle delay [src: Rodríguez et al.,
    "New positive-sequence voltage detector for grid synchronization of power converters under faulty grid
    conditions", IEEE PESC 2006 (the PSC, there with a SOGI for q); Svensson, Bongiorno, Sannino, "Practical
    implementation of delayed signal cancellation method for phase-sequence separation", IEEE Trans. Power
    Delivery 22(1), 2007 (the delay)]. In the common frame x = s e^{-j w0 t}, so j s(t - T0/4) e^{-j w0 t} =
    x(t - T0/4): a two-tap mean, a notch at 100 Hz (the negative sequence V2 e^{-j 2 w0 t}) that passes the
    positive sequence unchanged and, in the space vector, drops the zero sequence. Settles in T0/4 (5 ms);
    before ``d`` samples exist the first sample stands in for the past (a start at rest)."""
    x = np.asarray(x_park)
    past = np.concatenate([np.repeat(x[:1], d, axis=0), x[:-d] if d else x[:0]], axis=0)[: len(x)]
    return 0.5 * (x + past)


class QuarterCycleDsc:
    """:func:`positive_sequence_dsc` one sample at a time (the stepped run's per-step measurement): a ring of
    the last ``d`` + 1 Park phasors, prefilled with ``x0`` (the load flow's: a start at rest)."""

    def __init__(self, d: int, x0: complex):
        self.d = d
        self.ring = [complex(x0)] * (d + 1)

    def push(self, k: int, x: complex) -> complex:
        """Store step ``k``'s phasor, return the positive sequence at k (needs step k - d stored earlier)."""
        n = self.d + 1
        self.ring[k % n] = x
        return 0.5 * (x + self.ring[(k - self.d) % n])

    def store(self, k: int, x: complex) -> None:
        """Store step ``k``'s phasor only (a step whose output nobody reads, but k + d's will)."""
        self.ring[k % (self.d + 1)] = x
