"""Where each part of the plant's state lives in its one complex state vector X.

    X = [turbines (NS rows of N, row-major: turbine.IF ... turbine.XB),
         condenser (condenser.NX entries: DELTA ... EFD),
         grid source (GRID_ANGLE, GRID_SPEED, GRID_PM),
         PCC PLL (PLL_ANGLE, PLL_INTEGRATOR)]

Every entry but the filter current i and the current-PI integrator xi is real (zero imaginary part).
The ViSC law states of hd_visc turbines are a separate real array (``Plant.xl``, sdc_unit.law).
Both the general path (plant/equations.py) and the compiled kernels (plant/kernels.py) use these
offsets.
"""

from __future__ import annotations

from plant.condenser import NX as SC_NX
from plant.turbine import NS

GRID_ANGLE, GRID_SPEED, GRID_PM = range(3)  # grid source: theta_g [rad], omega_g [p.u.], P_m [p.u.]
GRID_NX = 3
PLL_ANGLE, PLL_INTEGRATOR = range(2)  # PCC PLL: theta [rad], x_p [p.u.]
PLL_NX = 2


class StateLayout:
    """Offsets of the parts of X for N turbines."""

    def __init__(self, n: int):
        self.n = n
        self.condenser = NS * n
        self.grid = self.condenser + SC_NX
        self.pcc_pll = self.grid + GRID_NX
        self.size = self.pcc_pll + PLL_NX

    def turbines(self, X):
        """The turbine rows of X as an (NS, N) view."""
        return X[: self.condenser].reshape(NS, self.n)

    def tail(self, X) -> list[float]:
        """Condenser, grid source and PCC PLL states as Python floats (real parts)."""
        return X.real[self.condenser:].tolist()
