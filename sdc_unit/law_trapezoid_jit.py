"""The generic trapezoid (:mod:`sdc_unit.law_trapezoid`) compiled with numba: any law's ``rhs``
compiled as written (each function of the law's module compiled with that module's namespace, in
which the functions it calls are their compiled versions, as :mod:`sdc_unit.law_jit` compiles
``law_kernels``) and one call stepping every column. Per column the fixed-point iteration stops when
that column has converged (the numpy engine stops when all have): the two agree to the tolerance,
not bit for bit (tests/unit/test_law_registry.py). Not cached on disk (a kernel taking a function
argument is compiled per law at the first call, about a second: ``ControllerBank.warm_up`` makes it)."""

from __future__ import annotations

import sys
import types
from functools import cache

import numpy as np
from numba import njit


@cache
def compiled_rhs(rhs: types.FunctionType):
    """``rhs`` compiled, the plain functions of its module's namespace (its helpers) compiled with it."""
    module = sys.modules[rhs.__module__]
    scope = dict(vars(module))
    for name, f in vars(module).items():
        if isinstance(f, types.FunctionType):
            copy = types.FunctionType(f.__code__, scope, name, f.__defaults__, f.__closure__)
            scope[name] = njit(error_model="numpy")(copy)  # lazily: only what rhs calls is compiled
    return scope[rhs.__name__]


@njit(error_model="numpy")
def advance_columns(rhs, x, f, m, c, ts, tol, max_iterations, wrap_row, out):
    """One trapezoid sample of every column j: x[:, j] from x_{k-1} = x[:, j], f_{k-1} = f[:, j] and
    m_k = m[:, j] (parameters c[:, j]); x, f (= rhs at the new state) and out written in place.
    Returns the largest number of iterations a column took."""
    nx, n = x.shape
    dx = np.empty(nx)
    o = np.empty(out.shape[0])
    half = 0.5 * ts
    most = 0
    for j in range(n):
        x0 = x[:, j].copy()
        f0 = f[:, j].copy()
        mj = m[:, j].copy()
        cj = c[:, j].copy()
        xc = x0 + ts * f0
        for it in range(1, max_iterations + 1):
            rhs(xc, mj, cj, dx, o)
            nxt = x0 + half * (f0 + dx)
            err = np.max(np.abs(nxt - xc))
            xc = nxt
            if it > most:
                most = it
            if err <= tol:
                break
        if wrap_row >= 0:
            xc[wrap_row] = np.arctan2(np.sin(xc[wrap_row]), np.cos(xc[wrap_row]))
        rhs(xc, mj, cj, dx, o)
        x[:, j] = xc
        f[:, j] = dx
        out[:, j] = o
    return most
