"""F6-F9's cases on the dynamic-phasor network (plant/dynamic_network.py): plant/cases.py's own
functions with their Plant built on that network, for report/exp_network_model.py (NM) and F6's
simulated first peak (report/exp_grid.py)."""

from __future__ import annotations

import contextlib

import plant.cases
from plant.dynamic_network import DYNAMIC_STEP_S

DYN_T0 = 0.1  # s: the event of a dynamic run (the F-experiments': 1 s)


@contextlib.contextmanager
def dynamic_network():
    """Inside, plant/cases.py's functions build their Plant on the dynamic-phasor network at
    DYNAMIC_STEP_S (the parameters and the set-up are theirs; only the network model and the step change)."""
    original = plant.cases.Plant

    def build(pp, *args, **kwargs):
        pp.network_model = "dynamic_phasor"
        return original(pp, *args, **{**kwargs, "step_s": DYNAMIC_STEP_S})

    plant.cases.Plant = build
    try:
        yield
    finally:
        plant.cases.Plant = original


def dynamic(make, *args, **kwargs):
    """``make(*args, **kwargs)`` (a case function, or a lambda calling one) on the dynamic network."""
    with dynamic_network():
        return make(*args, **kwargs)


def _every(step_s: float, dt: float = 1e-3) -> int:
    return max(1, int(round(dt / step_s)))
