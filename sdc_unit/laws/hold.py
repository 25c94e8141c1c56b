"""The "hold" law: network only, no dynamics. Every measurement is answered with the converter
voltage of the operating point it saw first (``v + (R_f + jX_f)·i``), so packets flow with realistic
sizes and timing at negligible CPU cost. Its controllers offer the bank what every law's do
(:class:`sdc_unit.law_trapezoid.TrapezoidControllers` lists it)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sdc_unit.law_spec import Law
from sdvisc.vocabulary import CTRL_OUTPUTS, FILTER_R_F_PU, FILTER_X_F_PU


@dataclass(frozen=True)
class HoldParams:
    """No parameters."""


class HoldControllers:
    """``n`` held converter voltages (``r_f``, ``x_f``: the converter filter, p.u.)."""

    answers_datagrams = False

    def __init__(self, n: int, r_f: float = FILTER_R_F_PU, x_f: float = FILTER_X_F_PU) -> None:
        self.z_f = complex(r_f, x_f)
        self.rp: dict[str, np.ndarray] = {}
        self.active = np.zeros(n, dtype=bool)
        self.last = {k: np.zeros(n) for k in CTRL_OUTPUTS}
        self.last["omega"][:] = 1.0
        self.last_limited = np.zeros(n, dtype=bool)

    def initialise(self, index, meas) -> None:
        cols = np.atleast_1d(np.asarray(index, dtype=np.intp))
        v = np.asarray(meas.v_d, dtype=float) + 1j * np.asarray(meas.v_q, dtype=float)
        i = np.asarray(meas.i_d, dtype=float) + 1j * np.asarray(meas.i_q, dtype=float)
        held = v + self.z_f * i
        self.last["v_ref_d"][cols], self.last["v_ref_q"][cols] = held.real, held.imag
        self.last["e_mag"][cols] = np.abs(held)
        self.active[cols] = True

    def deactivate(self, index) -> None:
        self.active[np.asarray(index, dtype=np.intp)] = False

    def set_params(self, index, **changes) -> None:
        if changes:
            raise KeyError(f"the hold law has no run-time parameters: {sorted(changes)}")

    def track(self, meas, index=None) -> None:
        """Nothing to follow: the held voltage is the first operating point's."""

    def advance_slots(self, slots, rows) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        slots = np.asarray(slots, dtype=np.intp)
        return self.active[slots], np.array([self.last[k][slots] for k in CTRL_OUTPUTS]), self.last_limited[slots]


LAW = Law(name="hold", params_type=HoldParams, bank=lambda n, step_s, method, dtype: HoldControllers(n))
