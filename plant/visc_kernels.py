"""The plant's compiled evaluation and step with hd_visc turbines (docs/plant.md, Integration).

An evaluation is the network solve (``kernels.solve_network``), the ViSC law of every hd_visc
turbine on its terminal measurements (``sdc_unit.law_jit.law_rhs``: the law's own equations,
compiled), which gives their converter voltages, then the rest of the right-hand side
(``kernels.rhs_given_network``); the step is the ETD2 step of ``kernels.step`` on the plant state
and, with its own coefficients (c = 0: Heun), on the law states -- the update ``Plant._etd2`` makes
with the numpy law, in one call.

Arguments as in plant/kernels.py, and: ``xl`` the law states (rows sdc_unit.law_kernels.STATE_NAMES,
one C-contiguous column per hd_visc turbine), ``l1``/``dxl`` their derivatives, ``visc_idx`` the
hd_visc turbines, ``law_c`` their law parameters (rows ``PARAM_ROWS``, ``law.param_rows``),
``law_rows`` the law's outputs (rows ``OUT_ROWS``), ``v_hold`` the held converter-voltage
references (a copy gets the law's voltages; ``v_hold`` is not written).

The entry points are cached on disk with a closure key over the sources they compile in (see
sdc_unit/law_jit.py and sdc_unit/tustin_jit.py): an edit of any of those files recompiles them.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from plant import condenser, integrator, kernels, layout, slots, turbine, turbine_kernels, turbine_laws
from plant.integrator import etd2_correct, etd2_predict
from plant.kernels import rhs_given_network, solve_network, split
from plant.slots import Const
from plant.turbine import IF, TH, XP, W
from plant.turbine_kernels import pll_error
from sdc_unit import law_kernels as L
from sdc_unit.law_jit import law_rhs, source_key

_OPTS = dict(error_model="numpy")


@njit(**_OPTS)
def law_turbines(X, node_v, constants, visc_idx, xl, law_c, v_ext, dxl, law_rows):
    """The law of the hd_visc turbines: derivatives into ``dxl``, outputs into ``law_rows``, their
    converter voltages into ``v_ext``. Measurements as ``RightHandSide._meas_arrays``."""
    n = node_v.size - 2
    kp_pll = constants[Const.kp_pll]
    m = np.empty(len(L.MEAS_ROWS))
    for k in range(visc_idx.size):
        j = visc_idx[k]
        v = node_v[j]
        i = X[IF * n + j]
        theta = X[TH * n + j].real
        e_v = pll_error((v * complex(math.cos(theta), -math.sin(theta))).imag, v.real, v.imag)
        m[L.M_VD], m[L.M_VQ], m[L.M_ID], m[L.M_IQ] = v.real, v.imag, i.real, i.imag
        m[L.M_P] = v.real * i.real + v.imag * i.imag
        m[L.M_Q] = v.imag * i.real - v.real * i.imag
        m[L.M_VDC] = math.sqrt(max(X[W * n + j].real, 1e-4))
        m[L.M_OMEGA] = 1.0 + kp_pll * e_v + X[XP * n + j].real
        law_rhs(xl[:, k], m, law_c[:, k], dxl[:, k], law_rows[:, k])
        v_ext[j] = complex(law_rows[L.O_V_REF_D, k], law_rows[L.O_V_REF_Q, k])


@njit(**_OPTS)
def rhs_visc(X, xl, v_load, constants, slow, mode, v_ext, i_hold, soc, z_planes, visc_idx, law_c, dX, dxl,
             node_v, rows, scalars, law_rows, want):
    """dX and dxl of (X, xl): network solve, law, rest of the right-hand side."""
    sources = solve_network(X, v_load, constants, z_planes, node_v)
    law_turbines(X, node_v, constants, visc_idx, xl, law_c, v_ext, dxl, law_rows)
    rhs_given_network(X, node_v, sources, constants, slow, mode, v_ext, i_hold, soc, dX, rows, scalars, want)


def _entries(compiled_in: int):
    """The cached entry points; ``compiled_in`` (a hash of the sources compiled in) is a closure
    constant, so it is part of numba's cache key."""

    @njit(cache=True, **_OPTS)
    def evaluate_visc(X, xl, v_load, constants, slow, mode, v_hold, i_hold, soc, z_planes, visc_idx, law_c,
                      out, dxl, rows, law_rows, want):
        """One evaluation of (X, xl) into ``out`` (dX, node_v, scalars; see kernels.split), ``dxl``,
        ``rows`` (with ``want``) and ``law_rows``."""
        if compiled_in == 0:  # never true: puts the key into the closure
            return
        _, dX, node_v, scalars = split(out, X.size, slow.shape[1])
        rhs_visc(X, xl, v_load, constants, slow, mode, v_hold.copy(), i_hold, soc, z_planes, visc_idx, law_c,
                 dX, dxl, node_v, rows, scalars, law_rows, want)

    @njit(cache=True, **_OPTS)
    def step_visc(X, k1, coefficients, xl, l1, law_coefficients, v_load, constants, slow, mode, v_hold, i_hold,
                  soc, soc_next, z_planes, visc_idx, law_c, out, xl_next, dxl_next, rows, law_rows,
                  evaluate_next):
        """One ETD2 step from (X, xl) with first stages (k1, l1) into ``out``'s X+ and ``xl_next``
        and, with ``evaluate_next``, the evaluation of (X+, xl+) into the rest of ``out``,
        ``dxl_next``, ``rows``, ``law_rows``; the batteries' SOC as in ``kernels.step``."""
        if compiled_in == 0:  # never true (see above)
            return
        size = X.size
        x_next, dX_next, node_v, scalars = split(out, size, slow.shape[1])
        v_ext = v_hold.copy()
        a = np.empty(size, dtype=np.complex128)
        k2 = np.empty(size, dtype=np.complex128)
        a_f, k1_f, k2_f = a.view(np.float64), k1.view(np.float64), k2.view(np.float64)
        xa = np.empty_like(xl)
        l2 = np.empty_like(xl)
        xa_f, l1_f, l2_f = xa.reshape(xa.size), l1.reshape(l1.size), l2.reshape(l2.size)
        etd2_predict(X.view(np.float64), k1_f, coefficients[1], a_f)
        etd2_predict(xl.reshape(xl.size), l1_f, law_coefficients[1], xa_f)
        rhs_visc(a, xa, v_load, constants, slow, mode, v_ext, i_hold, soc, z_planes, visc_idx, law_c, k2, l2,
                 node_v, rows, scalars, law_rows, False)
        etd2_correct(a_f, k1_f, k2_f, coefficients[0], coefficients[2], x_next.view(np.float64))
        etd2_correct(xa_f, l1_f, l2_f, law_coefficients[0], law_coefficients[2], xl_next.reshape(xl_next.size))
        if evaluate_next:
            rhs_visc(x_next, xl_next, v_load, constants, slow, mode, v_ext, i_hold, soc_next, z_planes,
                     visc_idx, law_c, dX_next, dxl_next, node_v, rows, scalars, law_rows, True)

    return evaluate_visc, step_visc


evaluate_visc, step_visc = _entries(source_key(kernels, turbine_kernels, turbine_laws, integrator, slots, turbine,
                                                condenser, layout))
