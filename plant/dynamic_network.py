"""Dynamic-phasor (dq) network: the passive elements with their own dynamics, for a cross-check of
the quasi-static network (issue 28 item 3; docs/plant.md "Network models").

In the synchronously rotating frame (ω0) a phasor x(t) of a 50 Hz quantity obeys, for each element,

    RL branch (a → b, z = r + j x at ω0, L = x/ω0):   L di/dt = Δv − (r + j x) i
    shunt capacitance (node → ground, b = ω0 C):        C dv/dt = i − j b v

(Δv = v_a − v_b). Both are integrated with the trapezoidal rule (slightly damped: θ-method, :data:`THETA`) at the plant's
step h, as an EMT program does (Dommel's companion model): every element becomes a conductance g_e in parallel with
a history current η,

    i_{k+1} = g_e Δv_{k+1} + η_k,   η_k = c1 Δv_k + c2 i_k,

    RL:  α = 2L/h,  g_e = 1/(α + z),  c1 = g_e,  c2 = g_e (α − z)
    C:   β = 2C/h,  g_e = β + j b,    c1 = −(β − j b),  c2 = −1

(written for the trapezoidal rule, θ = 1/2; the code uses the θ-method with :data:`THETA`, whose
coefficients reduce to these at θ = 1/2)

so the network is still one linear solve per evaluation, G v = u − Aᵀη, with G assembled from the
g_e exactly as Y is from the 1/z and j b (in steady state, Δv constant, both give the same v). The
history advances once per plant step from the node voltages of the step's first stage (the
partitioned scheme of a simulator interfacing its controls with its network solution). Elements
whose parameters change (SCR) keep their currents; the η are recomputed with the new coefficients.

The two sources are voltages behind RL branches of their own: the grid's E behind its Thevenin
impedance and the condenser's E'' behind r_a + j x''_d (its stator current then has the dynamics of
that branch: with the network's transients modelled, the machine's stator transients must be too, or
a reactance fixed at ω0 would meet inductances that are not, and the pair has spurious modes — with
x''_d algebraic the farm with its SC oscillated at 14 Hz and grew after a 1 % step of E_grid). The
fault's sequence shunt Z2 + Z0 + 3 Z_f is an RL element switched in at the fault. The load stays a
current.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sdvisc.vocabulary import OMEGA0

GROUND = -1
"""Far end of a shunt element."""
GRID_SOURCE = -2
"""Far end of the grid's Thevenin branch: the node at E_grid."""
SC_SOURCE = -3
"""Far end of the condenser's subtransient branch: the node at its E''."""

BREAKER_TAU_S = 0.01
"""Time constant over which the current of an element switched out (a fault cleared, a turbine
unplugged) falls to zero [s] [engineering reason: a breaker interrupts at a current zero, within half
a cycle at 50 Hz; a phasor's magnitude never passes zero, and cutting an inductive current in one step
would put L di/dt = ∞ on the network]."""

THETA = 0.52
"""Weight of the new step in the θ-method (θ = 1/2: the trapezoidal rule) [engineering reason: the
trapezoidal rule does not damp at the Nyquist rate, so after any discontinuity (an SCR change, a
switching) the node voltages of inductive cut-sets chatter ± every step for ever — sampled by the
converters' controls every step, it biased the farm's operating point by 2 % after SCR 7.14 → 3; at
θ = 0.52 that chatter falls by (1 − θ)/θ = 0.92 per step (3e-4 after 5 ms) while a 50 Hz mode is
damped by ≈ (θ − 1/2)(ω0 h)² = 5e-6 per step more than it should (EMT programs do the same job with
critical damping adjustment); steady states are exact whatever θ]."""

DYNAMIC_STEP_S = 50e-6
"""Plant step with the dynamic-phasor network [s] [src: RTDS: 50 µs typical; the same step as the HD
reference, plant/hd_reference.py]; the network's fastest modes (cable/transformer resonances, a few
hundred Hz to a few kHz) need a simulator's step, not the SDC's 0.67 ms."""


@dataclass
class Elements:
    """The network's passive elements: RL branches and shunt capacitances, in a fixed order (an
    unplugged turbine's transformer stays in the list, inactive, so the history keeps its place)."""

    a: list[int] = field(default_factory=list)
    b: list[int] = field(default_factory=list)
    z: list[complex] = field(default_factory=list)  # RL: r + j x; capacitance: 0
    bsh: list[float] = field(default_factory=list)  # capacitance: its susceptance b = ω0 C; RL: 0
    active: list[bool] = field(default_factory=list)

    def rl(self, a: int, b: int, z: complex, active: bool = True) -> None:
        self._add(a, b, complex(z), 0.0, active)

    def shunt_c(self, node: int, b: float) -> None:
        if b > 0.0:
            self._add(node, GROUND, 0j, float(b), True)

    def _add(self, a, b, z, bsh, active) -> None:
        self.a.append(a)
        self.b.append(b)
        self.z.append(z)
        self.bsh.append(bsh)
        self.active.append(active)

    def steady_admittance(self) -> np.ndarray:
        """1/z of the RL branches and j b of the capacitances (0 where inactive): the Y of each."""
        z, bsh = np.array(self.z), np.array(self.bsh)
        y = np.where(bsh > 0.0, 1j * bsh, 1.0 / np.where(bsh > 0.0, 1.0, z))
        return y * np.array(self.active)


class Companion:
    """The trapezoidal companion model of ``elements`` at step ``h`` and the network's history."""

    def __init__(self, elements: Elements, n_nodes: int, h: float):
        self.n_nodes = n_nodes
        self.h = float(h)
        ext = {GROUND: n_nodes, GRID_SOURCE: n_nodes + 1, SC_SOURCE: n_nodes + 2}
        self.a = np.array([ext.get(x, x) for x in elements.a])
        self.b = np.array([ext.get(x, x) for x in elements.b])
        z, bsh, on = np.array(elements.z), np.array(elements.bsh), np.array(elements.active, dtype=float)
        cap = bsh > 0.0
        th = THETA
        l_h = z.imag / OMEGA0 / self.h  # L/h of the RL branches
        c_h = bsh / OMEGA0 / self.h  # C/h of the capacitances
        den = 1.0 / np.where(cap, 1.0, l_h + th * z)
        self.g = np.where(cap, c_h / th + 1j * bsh, th * den) * on
        self.c1 = np.where(cap, -(c_h - (1.0 - th) * 1j * bsh) / th, (1.0 - th) * den) * on
        self.c2 = np.where(cap, -(1.0 - th) / th, (l_h - (1.0 - th) * z) * den) * on
        self.y_steady = elements.steady_admittance()

    def stamp(self, y: np.ndarray, admittance: np.ndarray) -> None:
        """Add every element's ``admittance`` between its nodes into ``y`` (ground and the grid
        source are not nodes of y)."""
        n = self.n_nodes
        for a, b, ye in zip(self.a, self.b, admittance, strict=True):
            if a < n:
                y[a, a] += ye
            if b < n:
                y[b, b] += ye
            if a < n and b < n:
                y[a, b] -= ye
                y[b, a] -= ye

    def g_of(self, index: int) -> complex:
        return complex(self.g[index])


class History:
    """The elements' currents and voltages at the last step, and what they add to the solve."""

    def __init__(self, n_elements: int):
        self.i = np.zeros(n_elements, dtype=complex)
        self.dv = np.zeros(n_elements, dtype=complex)
        self.eta = np.zeros(n_elements, dtype=complex)
        self.i_out = np.zeros(n_elements, dtype=complex)  # currents of elements switched out, decaying

    @staticmethod
    def element_voltages(comp: Companion, v_nodes: np.ndarray, e_grid: complex, e_sc: complex) -> np.ndarray:
        v_ext = np.r_[v_nodes, 0.0, e_grid, e_sc]
        return v_ext[comp.a] - v_ext[comp.b]

    def start(self, comp: Companion, v_nodes: np.ndarray, e_grid: complex, e_sc: complex) -> None:
        """Steady state at the node voltages ``v_nodes`` (every element's current dv·y)."""
        self.dv = self.element_voltages(comp, v_nodes, e_grid, e_sc)
        self.i = comp.y_steady * self.dv
        self.refresh(comp)

    def advance(self, comp: Companion, v_nodes: np.ndarray, e_grid: complex, e_sc: complex) -> None:
        """One step on: the currents at the solved node voltages ``v_nodes``, then the next η."""
        self.dv = self.element_voltages(comp, v_nodes, e_grid, e_sc)
        self.i = comp.g * self.dv + self.eta
        self.i_out *= np.exp(-comp.h / BREAKER_TAU_S)
        self.refresh(comp)

    def switch(self, was_active: np.ndarray, comp: Companion) -> None:
        """Elements switched in start from rest; those switched out hand their current over to the
        decaying source."""
        active = comp.g != 0.0
        closing, opening = active & ~was_active, was_active & ~active
        self.i_out[opening] += self.i[opening]
        self.i_out[closing] = 0.0  # closed again before its old current had decayed: the element carries it
        self.i[opening | closing] = 0.0
        self.dv[opening | closing] = 0.0

    def refresh(self, comp: Companion) -> None:
        """η from the stored currents and voltages with ``comp``'s (present) coefficients."""
        self.eta = comp.c1 * self.dv + comp.c2 * self.i + self.i_out

    def node_injection(self, comp: Companion) -> np.ndarray:
        """−Aᵀη on the network's nodes: the history's share of the right-hand side."""
        inj = np.zeros(comp.n_nodes + 3, dtype=complex)
        np.add.at(inj, comp.a, -self.eta)
        np.add.at(inj, comp.b, self.eta)
        return inj[: comp.n_nodes]

    def current(self, comp: Companion, index: int, dv: complex) -> complex:
        """Element ``index``'s current (a → b) at its voltage ``dv`` in the present step."""
        return complex(comp.g[index] * dv + self.eta[index])
