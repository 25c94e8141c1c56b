"""Filling numba's cache of the plant's compiled step before a run (plant/kernels.py).

``warm_up`` runs the code paths of a real-time run once on a small scratch plant; ``precompile``
is what ``./testbed`` and the Docker image call so that a plant started in a run does not spend
seconds compiling.
"""

from __future__ import annotations

from dataclasses import replace

from plant.params import PlantParams
from plant.sim import Plant


def warm_up(params: PlantParams | None = None, step_s: float = 0.67e-3) -> None:
    """Run the code paths of a real-time run once on a 2-turbine scratch plant (``params``):
    remote references every step, a fault on and off, back to grid following. numba compiles each
    kernel (or loads it from its cache: tens of ms each) at its first call; the plant service calls
    this before t = 0, not at the first CTRL packet (a 45 ms stall of the paced loop, measured)."""
    p = Plant(params, n_turbines=2, step_s=step_s)
    p.set_mode([1], "remote")
    for k in range(30):
        if k in (10, 20):
            p.fault(k == 10)
        m = p.measurements()
        p.apply_remote([1], m["v_d"][1:], m["v_q"][1:], m["i_d"][1:], m["i_q"][1:])
        p.step()
        if k % 5 == 0:
            p.outputs()
    p.set_mode([1], "grid_following")
    for _ in range(3):
        p.step()
        p.measurements()


def precompile() -> None:
    """Fill numba's on-disk cache (both remote-apply variants: ``./testbed`` and the Docker image)."""
    base = PlantParams()
    for apply in ("v_ref", "i_ref"):
        warm_up(replace(base, turbine=replace(base.turbine, remote_apply=apply)))
