"""The ViSC law of the paper as a registry entry: its parameters (:class:`sdc_unit.params.ViscParams`,
the run-time ones marked there), its equations (:func:`sdc_unit.law_kernels.law_rhs`), its bumpless
start (:func:`sdc_unit.law.initial_state`) and its hand-derived discretisations
(:class:`sdc_unit.discrete.DiscreteVisc`: Tustin, trapezoid-cumulative, Euler; the compiled Tustin
engine). The generic trapezoid (:mod:`sdc_unit.law_trapezoid`) runs it too (tests/unit/test_law_registry.py
compares the two)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from sdc_unit import law_kernels
from sdc_unit.blocks import METHODS
from sdc_unit.law_spec import Law
from sdc_unit.params import ViscParams
from sdvisc.vocabulary import MEAS_FIELDS


def _initial_state(m: np.ndarray, p: ViscParams) -> np.ndarray:
    from sdc_unit.law import initial_state

    return initial_state(SimpleNamespace(**dict(zip(MEAS_FIELDS, m))), p)


def _bank(n: int, step_s: float, method: str, dtype: str):
    from sdc_unit.discrete import DiscreteVisc

    return DiscreteVisc(n, ViscParams(), ts=step_s, method=method,
                        dtype=np.float32 if dtype == "float32" else np.float64)


LAW = Law(name="visc", params_type=ViscParams, state_names=law_kernels.STATE_NAMES, out_rows=law_kernels.OUT_ROWS,
          rhs=law_kernels.law_rhs, param_row_names=law_kernels.PARAM_ROWS, initial_state=_initial_state, bank=_bank,
          methods=METHODS)
