"""The law's algebraic helpers, written once for numpy and for numba.

Each function uses only arithmetic and numpy ufuncs (``np.cos``, ``np.hypot``, ``np.maximum``) and
no branch on its arguments, so the same Python function

* runs on arrays of N turbines in :mod:`sdc_unit.law` (continuous law) and in the block-by-block
  pass of :class:`sdc_unit.discrete.DiscreteVisc`, and
* compiles for scalars with ``numba.njit`` in :mod:`sdc_unit.tustin_jit` (the compiled Tustin
  sample), where numba maps the ufuncs to the same libm calls numpy makes: float64 results are
  bit-identical between the two (tests/unit/test_sdc_engines.py).

Dependencies: numpy only.
"""

from __future__ import annotations

import numpy as np


def qsem_current(e_mag, delta, vf_d, vf_q, omega, r_v, l_v):
    """Quasi-stationary electrical model i* = (E e^{j delta} - v_f)/(r_v + j omega l_v); returns (i_d, i_q)."""
    ed = e_mag * np.cos(delta) - vf_d
    eq = e_mag * np.sin(delta) - vf_q
    x = omega * l_v
    den = r_v * r_v + x * x
    return (ed * r_v + eq * x) / den, (eq * r_v - ed * x) / den


def circular_limit(i_d, i_q, i_max):
    """Circular limiter: scale |i| down to i_max keeping the angle. Returns (i_d, i_q, limited).

    The scale is i_max / max(|i|, i_max): exactly 1 while |i| <= i_max (x/x is exact), i_max/|i|
    above it; no division by zero for i_max > 0."""
    mag = np.hypot(i_d, i_q)
    scale = i_max / np.maximum(mag, i_max)
    return i_d * scale, i_q * scale, mag > i_max
