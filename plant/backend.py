"""The one interface between the plant service and a plant model (issue 40 item 6).

The plant service (plant/service/main.py, plant/service/core.py, the recorder plant/service/recorder.py, the
calibration's pilot scenarios/calibrate.py) drives a model only through :class:`PlantBackend`; the phasor
farm (:class:`plant.sim.Plant`), the infinite-bus model (:class:`plant.minimal.MinimalPlant`) and the EMT
arrangement on DPsim (:class:`plant.emt.service_backend.EmtServiceBackend`) implement it, chosen by
``plant.model`` in :func:`plant.service.model.build_model` (which also builds them: the constructor is
the "init"). Scenario events reach a model through optional methods that plant/settable.py reads off
its class (``fault``, ``load_step``, ``set_scr``, ``set_<param>``/``get_<param>``), so ``sdvisc check``
refuses what a model cannot apply; :func:`close_backend` releases what one holds (DPsim's simulation).
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np


@runtime_checkable
class PlantBackend(Protocol):
    """What the plant service needs of a model. Indices are converter indices (``build_model`` maps
    host names to them); values per unit of each converter's rating, phasors in the common frame."""

    n: int
    """Converters (the length of every per-converter array)."""
    k: int
    """Steps taken."""
    step_s: float
    """The step, Ts (s)."""

    def set_mode(self, index, mode: str) -> None:
        """``remote`` (apply the SDC's CTRL from now on, hold the present reference until the first) or
        the converter's own control (``grid_following``; the phasor plant also ``hd_visc``)."""

    def apply_remote(self, index: np.ndarray, v_ref_d: np.ndarray, v_ref_q: np.ndarray,
                     i_ref_d: np.ndarray | None = None, i_ref_q: np.ndarray | None = None) -> None:
        """The newest CTRL's references of converters ``index``: applied from the next :meth:`step` on."""

    def step(self) -> None:
        """Advance one step (Ts) to t = (k + 1) Ts."""

    def measurements(self) -> dict[str, np.ndarray]:
        """Per converter, what its MEAS carries (:data:`sdvisc.vocabulary.MEAS_FIELDS`)."""

    def recorded(self) -> dict:
        """The recorder's state: ``t``, ``v_pcc``, ``f_pcc_hz`` and per converter ``p``, ``q``, ``i_mag``,
        ``mode`` (and ``soc``, ``p_batt`` where the model has batteries)."""


def close_backend(model) -> None:
    """Release what ``model`` holds, if anything (``close()``: the EMT backend stops DPsim)."""
    close = getattr(model, "close", None)
    if callable(close):
        close()
