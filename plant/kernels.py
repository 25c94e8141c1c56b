"""The plant's equations for the usual case, compiled with numba (docs/plant.md, Integration).

This is the implementation of the usual case: the reduced network solve, the turbines with the
held slow terms (grid-following, remote with v_ref or i_ref, and hd_visc turbines whose converter
voltage the law supplies; every limiter and the DC-link batteries, plant/turbine_kernels.py), the
synchronous condenser, the grid source and the PCC PLL, and the whole ETD2 step around them
(plant/integrator.py). The general numpy path (plant/equations.py, turbine.py, condenser.py)
evaluates what is left: unplugged turbines and slow terms evaluated at every stage. The equations
are those of docs/plant.md.

The entry points (``_entries``) are cached on disk with a closure key over the sources they
compile in (``sdc_unit.law_jit.source_key``, as in plant/visc_kernels.py): an edit of any of those
files recompiles them; the functions they call are not cached themselves.

Arguments, by name: ``X`` the complex state (plant/layout.py), ``constants`` (slots ``Const``),
``slow`` the held slow terms (rows ``Slow``, N columns), ``mode``/``v_ext``/``i_hold`` the turbine
modes, converter-voltage references (held remote references or the law's) and held current
references, ``z_planes`` the real and imaginary planes of ``Network.zred``, transposed,
``node_v`` the reduced node voltages [turbine terminals, PCC, SC], ``rows`` the per-turbine real
results (slots ``Row``), ``scalars`` the complex scalars (slots ``Scalar``), ``soc`` the
batteries' held states of charge (``slow``'s row ``Slow.battery_on``: which are connected).

``out`` of ``evaluate``/``step``: one complex buffer [X+ (size) | dX (size) | node_v (N + 2) |
scalars]; see ``split``.
"""

from __future__ import annotations

import cmath
import math

import numpy as np
from numba import njit

from plant import condenser, integrator, layout, slots, turbine, turbine_kernels, turbine_laws
from plant.condenser import DELTA, ED2, EFD, EQ1, EQ2, OMEGA, XLL
from plant.condenser import NX as SC_NX
from plant.integrator import etd2_correct, etd2_predict
from plant.layout import GRID_ANGLE, GRID_NX, GRID_PM, GRID_SPEED, PLL_ANGLE, PLL_INTEGRATOR
from plant.slots import Const, Scalar, Slow
from plant.turbine import IF, NS, WR, XB, B
from plant.turbine_kernels import turbines_rhs
from sdc_unit.law_jit import source_key
from sdvisc.vocabulary import OMEGA0

N_SCALARS = len(Scalar)
_OPTS = dict(error_model="numpy")  # IEEE division as in numpy (cached: the entry points of _entries)


@njit(**_OPTS)
def split(out, size, n):
    """Views of an evaluation buffer: (X+, dX, node_v, scalars)."""
    s2 = 2 * size
    return out[:size], out[size:s2], out[s2:s2 + n + 2], out[s2 + n + 2:]


@njit(**_OPTS)
def solve_network(X, v_load, constants, z_planes, node_v):
    """Reduced network solve into ``node_v``; returns the sources (E_grid, E''_sc, I_load).
    ``v_load``: the PCC voltage the constant-PQ load is linearised at (the last solve's)."""
    m = node_v.size
    n = m - 2
    o = NS * n
    theta_g = X[o + SC_NX + GRID_ANGLE].real
    if theta_g != 0.0:
        e_grid = constants[Const.e_grid] * cmath.exp(1j * theta_g)
    else:
        e_grid = complex(constants[Const.e_grid], 0.0)
    e_sc = 0j
    if constants[Const.sc_connected] != 0.0:
        e_sc = complex(X[o + EQ2].real, -X[o + ED2].real) * cmath.exp(1j * X[o + DELTA].real)
    load = complex(constants[Const.load_re], constants[Const.load_im])
    i_load = 0j
    if load != 0j:
        i_load = load.conjugate() * v_load / max(abs(v_load) ** 2, 0.49)
    u_grid = e_grid * complex(constants[Const.y_grid_re], constants[Const.y_grid_im]) - i_load
    u_sc = e_sc * complex(constants[Const.y_sc_re], constants[Const.y_sc_im])
    z_re = z_planes[0]
    z_im = z_planes[1]
    v_re = np.zeros(m)
    v_im = np.zeros(m)
    for c in range(m):
        u = X[c] if c < n else (u_grid if c == n else u_sc)
        for r in range(m):
            v_re[r] += z_re[c, r] * u.real - z_im[c, r] * u.imag
            v_im[r] += z_re[c, r] * u.imag + z_im[c, r] * u.real
    for r in range(m):
        node_v[r] = complex(v_re[r], v_im[r])
    return e_grid, e_sc, i_load


@njit(**_OPTS)
def condenser_rhs(X, o, v_pcc, v_sc, e_sc, constants, dX):
    """Condenser derivatives (entries o ... o + 6) into dX; returns its current I_sc."""
    if constants[Const.sc_connected] == 0.0:
        for k in range(SC_NX):
            dX[o + k] = 0j
        return 0j
    delta, w, eq1, eq2 = X[o + DELTA].real, X[o + OMEGA].real, X[o + EQ1].real, X[o + EQ2].real
    ed2, xll, efd = X[o + ED2].real, X[o + XLL].real, X[o + EFD].real
    v_reg = abs(v_pcc) if constants[Const.avr_at_pcc] != 0.0 else abs(v_sc)
    i_sc = (e_sc - v_sc) / complex(constants[Const.z_sc_re], constants[Const.z_sc_im])
    i_machine = i_sc * 1j * cmath.exp(-1j * delta)
    i_d, i_q = i_machine.real, i_machine.imag
    u = constants[Const.avr_v_ref] - v_reg - constants[Const.m_q] * (v_sc * i_sc.conjugate()).imag
    d_efd = (constants[Const.avr_k] * (constants[Const.avr_ta_tb] * u + constants[Const.avr_1_minus_ta_tb] * xll)
             - efd) / constants[Const.avr_te]
    if (efd >= constants[Const.efd_max] and d_efd > 0) or (efd <= constants[Const.efd_min] and d_efd < 0):
        d_efd = 0.0
    dX[o + DELTA] = OMEGA0 * (w - 1.0)
    dX[o + OMEGA] = (-(ed2 * i_d + eq2 * i_q) - constants[Const.d_sc] * (w - 1.0)) / constants[Const.two_h_sc]
    dX[o + EQ1] = (efd - eq1 - constants[Const.xd_minus_xd1] * i_d) / constants[Const.td01]
    dX[o + EQ2] = (eq1 - eq2 - constants[Const.xd1_minus_xd2] * i_d) / constants[Const.td02]
    dX[o + ED2] = (-ed2 + constants[Const.xq_minus_xd2] * i_q) / constants[Const.tq02]
    dX[o + XLL] = (u - xll) / constants[Const.avr_tb]
    dX[o + EFD] = d_efd
    return i_sc


@njit(**_OPTS)
def grid_and_pll_rhs(X, o, v_pcc, e_grid, constants, dX):
    """Grid source (entries o ... o + 2) and PCC PLL (o + 3, o + 4) into dX; returns f_pcc [p.u.]."""
    h_grid = constants[Const.h_grid]
    if h_grid > 0.0:
        w_g, p_m = X[o + GRID_SPEED].real, X[o + GRID_PM].real
        i_g = (e_grid - v_pcc) * complex(constants[Const.y_grid_re], constants[Const.y_grid_im])
        p_e = (e_grid * i_g.conjugate()).real * constants[Const.grid_power_scale]
        dX[o + GRID_ANGLE] = OMEGA0 * (w_g - 1.0)
        dX[o + GRID_SPEED] = (p_m - p_e - constants[Const.d_grid] * (w_g - 1.0)) / (2.0 * h_grid)
        dX[o + GRID_PM] = (constants[Const.pm0] - (w_g - 1.0) / constants[Const.r_gov] - p_m) / constants[Const.t_gov]
    else:
        dX[o + GRID_ANGLE] = 0j
        dX[o + GRID_SPEED] = 0j
        dX[o + GRID_PM] = 0j
    p = o + GRID_NX
    x_pll = X[p + PLL_INTEGRATOR].real
    e_v = (v_pcc * cmath.exp(-1j * X[p + PLL_ANGLE].real)).imag / max(abs(v_pcc), 0.1)
    kp_pll = constants[Const.kp_pll]
    dX[p + PLL_ANGLE] = OMEGA0 * (kp_pll * e_v + x_pll)
    dX[p + PLL_INTEGRATOR] = constants[Const.ki_pll] * e_v
    return 1.0 + kp_pll * e_v + x_pll


@njit(**_OPTS)
def rhs_given_network(X, node_v, sources, constants, slow, mode, v_ext, i_hold, soc, dX, rows, scalars,
                      want):
    """dX of state X whose network solve is ``node_v`` with ``sources`` (solve_network)."""
    turbines_rhs(X, node_v, constants, slow, mode, v_ext, i_hold, soc, dX, rows, want)
    n = slow.shape[1]
    e_grid, e_sc, i_load = sources
    v_pcc, v_sc = node_v[n], node_v[n + 1]
    o = NS * n
    i_sc = condenser_rhs(X, o, v_pcc, v_sc, e_sc, constants, dX)
    f_pcc_pu = grid_and_pll_rhs(X, o + SC_NX, v_pcc, e_grid, constants, dX)
    if want:
        scalars[Scalar.i_sc] = i_sc
        scalars[Scalar.e_grid] = e_grid
        scalars[Scalar.e_sc] = e_sc
        scalars[Scalar.i_load] = i_load
        scalars[Scalar.f_pcc_pu] = f_pcc_pu


@njit(**_OPTS)
def rhs(X, v_load, constants, slow, mode, v_ext, i_hold, soc, z_planes, dX, node_v, rows, scalars, want):
    """The plant's right-hand side (no law): network solve, then ``rhs_given_network``."""
    sources = solve_network(X, v_load, constants, z_planes, node_v)
    rhs_given_network(X, node_v, sources, constants, slow, mode, v_ext, i_hold, soc, dX, rows, scalars, want)


@njit(**_OPTS)
def etd2_step(X, k1, coefficients, v_load, constants, slow, mode, v_ext, i_hold, soc, soc_next, z_planes, out, rows,
              evaluate_next):
    """One ETD2 step from X with first stage k1 (``Etd2Coefficients.rows``) into ``out``'s X+
    and, with ``evaluate_next``, the evaluation of X+ into the rest of ``out`` and ``rows``. The
    batteries' SOC is ``soc`` in the second stage and ``soc_next`` in X+'s evaluation (the SOC
    of the next step, plant/battery.py)."""
    size = X.size
    x_next, dX_next, node_v, scalars = split(out, size, slow.shape[1])
    a = np.empty(size, dtype=np.complex128)
    k2 = np.empty(size, dtype=np.complex128)
    a_f, k1_f, k2_f = a.view(np.float64), k1.view(np.float64), k2.view(np.float64)
    etd2_predict(X.view(np.float64), k1_f, coefficients[1], a_f)
    rhs(a, v_load, constants, slow, mode, v_ext, i_hold, soc, z_planes, k2, node_v, rows, scalars, False)
    etd2_correct(a_f, k1_f, k2_f, coefficients[0], coefficients[2], x_next.view(np.float64))
    if evaluate_next:
        rhs(x_next, v_load, constants, slow, mode, v_ext, i_hold, soc_next, z_planes, dX_next, node_v,
            rows, scalars, True)


@njit(**_OPTS)
def slow_terms(X, constants, v_wind, mppt, p_cmd, q_cmd, slow):
    """The slow mechanical terms (TurbineBank.slow_terms) into ``slow`` (rows ``Slow``)."""
    n = v_wind.shape[0]
    v_wind_rated, lambda_opt = constants[Const.v_wind_rated], constants[Const.lambda_opt]
    cp_opt = constants[Const.cp_opt]
    p_me_max, p_headroom = constants[Const.p_me_max], constants[Const.p_headroom]
    omega_r_ref = constants[Const.omega_r_ref]
    kp_beta, ki_beta, beta_max = constants[Const.kp_beta], constants[Const.ki_beta], constants[Const.beta_max]
    tau_beta, rate_beta, h_rotor = constants[Const.tau_beta], constants[Const.rate_beta], constants[Const.h_rotor]
    for j in range(n):
        w_r = X[WR * n + j].real
        beta = X[B * n + j].real
        v_ratio = v_wind[j] / v_wind_rated
        lam = lambda_opt * max(w_r, 0.05) / v_ratio
        li = 1.0 / (lam + 0.08 * beta) - 0.035 / (beta ** 3 + 1.0)
        cp = 0.5176 * (116.0 * li - 0.4 * beta - 5.0) * math.exp(-21.0 * li) + 0.0068 * lam
        p_aero = max(cp, 0.0) / cp_opt * v_ratio ** 3
        p_avail = min(p_me_max, max(p_aero, 0.0) + p_headroom)
        p_star = min(max(w_r, 0.0) ** 3, 1.0) if mppt[j] else p_cmd[j]
        e_w = w_r - omega_r_ref
        beta_ref_u = kp_beta * e_w + X[XB * n + j].real
        beta_ref = max(min(beta_ref_u, beta_max), 0.0)
        windup = (beta_ref_u <= 0.0 and e_w < 0) or (beta_ref_u >= beta_max and e_w > 0)
        inv_2hw = 1.0 / (2.0 * h_rotor * max(w_r, 0.1))
        slow[Slow.s_ref_re, j] = p_star
        slow[Slow.s_ref_im, j] = -q_cmd[j]
        slow[Slow.p_aero_over_2hw, j] = p_aero * inv_2hw
        slow[Slow.inv_2hw, j] = inv_2hw
        slow[Slow.d_beta, j] = max(min((beta_ref - beta) / tau_beta, rate_beta), -rate_beta)
        slow[Slow.d_xbeta, j] = 0.0 if windup else ki_beta * e_w
        slow[Slow.p_avail, j] = p_avail
        slow[Slow.p_aero, j] = p_aero


def _entries(compiled_in: int):
    """The cached entry points; ``compiled_in`` (a hash of the sources compiled in) is a closure
    constant, so it is part of numba's cache key (as in plant/visc_kernels.py)."""

    @njit(cache=True, **_OPTS)
    def evaluate(X, v_load, constants, slow, mode, v_ext, i_hold, soc, z_planes, out, rows):
        """One evaluation of X with its results (the cached first stage of the next step) into
        ``out`` (dX, node_v, scalars) and ``rows``."""
        if compiled_in == 0:  # never true: puts the key into the closure
            return
        _, dX, node_v, scalars = split(out, X.size, slow.shape[1])
        rhs(X, v_load, constants, slow, mode, v_ext, i_hold, soc, z_planes, dX, node_v, rows, scalars, True)

    @njit(cache=True, **_OPTS)
    def evaluate_given_network(X, node_v, sources, constants, slow, mode, v_ext, i_hold, soc, dX, rows,
                               scalars, want):
        """``rhs_given_network`` as an entry point (the hd_visc law in numpy between two kernels)."""
        if compiled_in == 0:  # never true (see above)
            return
        rhs_given_network(X, node_v, sources, constants, slow, mode, v_ext, i_hold, soc, dX, rows, scalars,
                          want)

    @njit(cache=True, **_OPTS)
    def step(X, k1, coefficients, v_load, constants, slow, mode, v_ext, i_hold, soc, soc_next, z_planes, out,
             rows, evaluate_next):
        """``etd2_step`` as an entry point: the step from the cached first stage k1."""
        if compiled_in == 0:  # never true (see above)
            return
        etd2_step(X, k1, coefficients, v_load, constants, slow, mode, v_ext, i_hold, soc, soc_next, z_planes, out,
                  rows, evaluate_next)

    @njit(cache=True, **_OPTS)
    def step_evaluating_first_stage(X, coefficients, v_load, constants, slow, mode, v_ext, i_hold, soc, z_planes,
                                    out, rows, evaluate_next):
        """The evaluation of X (its first stage k1, at the PCC voltage ``v_load`` of the last solve)
        and ``etd2_step`` from it in one call: the step after new remote references (or a command)
        made the cached first stage stale. The batteries' SOC is ``soc`` throughout (the caller
        takes this path without connected batteries). Returns the first stage's PCC voltage (the
        load linearisation point of the step and of the next evaluation)."""
        if compiled_in == 0:  # never true (see above)
            return 0j
        n = slow.shape[1]
        k1 = np.empty(X.size, dtype=np.complex128)
        _, _, node_v, scalars = split(out, X.size, n)
        rhs(X, v_load, constants, slow, mode, v_ext, i_hold, soc, z_planes, k1, node_v, rows, scalars, False)
        v_pcc = node_v[n]
        etd2_step(X, k1, coefficients, v_pcc, constants, slow, mode, v_ext, i_hold, soc, soc, z_planes, out, rows,
                  evaluate_next)
        return v_pcc

    @njit(cache=True, **_OPTS)
    def evaluate_network(X, v_load, constants, z_planes, node_v):
        """``solve_network`` as an entry point (the first half of an evaluation)."""
        if compiled_in == 0:  # never true (see above)
            return 0j, 0j, 0j
        return solve_network(X, v_load, constants, z_planes, node_v)

    @njit(cache=True, **_OPTS)
    def hold_slow_terms(X, constants, v_wind, mppt, p_cmd, q_cmd, slow):
        """``slow_terms`` as an entry point."""
        if compiled_in == 0:  # never true (see above)
            return
        slow_terms(X, constants, v_wind, mppt, p_cmd, q_cmd, slow)

    return evaluate, evaluate_given_network, step, step_evaluating_first_stage, evaluate_network, hold_slow_terms


# the cached entry points, keyed by the sources they compile in
evaluate, evaluate_given_network, step, step_evaluating_first_stage, evaluate_network, hold_slow_terms = _entries(
    source_key(turbine_kernels, turbine_laws, integrator, slots, turbine, condenser, layout))


@njit(cache=True, **_OPTS)  # these two compile in turbine.IF only
def remote_needs_action(X, rem, last_rx_step, k, step_s, trip_current, loss_s, fallback_enabled):
    """True if a remote turbine ``rem`` has a filter current above ``trip_current`` or, with the
    fall-back enabled, a newest reference ``loss_s`` or more old (``Commands._check_fallback``)."""
    n = last_rx_step.shape[0]
    for j in rem:
        if abs(X[IF * n + j]) > trip_current:
            return True
        if fallback_enabled and (k - last_rx_step[j]) * step_s >= loss_s:
            return True
    return False


@njit(cache=True, **_OPTS)
def store_remote(v_hold, i_hold, last_rx_step, idx, v_d, v_q, i_d, i_q, with_current, k):
    """Hold the received references of turbines ``idx`` (``Commands.apply_remote``), step ``k``."""
    n = v_hold.shape[0]
    for m in range(idx.shape[0]):
        j = idx[m]
        if j < 0 or j >= n:
            raise IndexError("turbine index out of range")
        v_hold[j] = complex(v_d[m], v_q[m])
        if with_current:
            i_hold[j] = complex(i_d[m], i_q[m])
        last_rx_step[j] = k
