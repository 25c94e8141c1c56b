"""The continuous ViSC law compiled with numba: :func:`sdc_unit.law_kernels.law_rhs` for one turbine.

The plant's compiled hd_visc path (plant/visc_kernels.py) calls ``law_rhs`` once per hd_visc
turbine on its columns (state, measurements, parameters; outputs and derivatives written in
place). It is not a second implementation: every function of :mod:`sdc_unit.law_kernels` is
compiled as written, each with a copy of that module's globals in which its siblings are their
compiled versions (numba calls compiled functions only), so ``law_rhs`` runs the same
``qsem_current``, ``circular_limit`` and ``friction_output`` as :mod:`sdc_unit.law` does on arrays.
tests/unit/test_sdc_law_jit.py holds the two to each other (bit-identical in float64).

The functions here are not cached on disk themselves; a cached kernel that calls them compiles
them in, and numba stamps its cache with that kernel's file only: such a kernel carries
:func:`source_key` (a hash of law_kernels.py) in its cache key, as :mod:`sdc_unit.tustin_jit` does.
"""

from __future__ import annotations

import hashlib
import inspect
import types

from numba import njit

from . import law_kernels


def _compile_module(module, **options) -> dict:
    """The module's functions compiled with ``njit(**options)``, by name, calling each other compiled."""
    scope = dict(vars(module))
    for name, f in vars(module).items():
        if isinstance(f, types.FunctionType) and f.__module__ == module.__name__:
            copy = types.FunctionType(f.__code__, scope, name, f.__defaults__, f.__closure__)
            scope[name] = njit(error_model="numpy", **options)(copy)  # IEEE division, as numpy
    return scope


_COMPILED = _compile_module(law_kernels)
law_rhs = _COMPILED["law_rhs"]


def source_key(*modules) -> int:
    """A hash of the source of law_kernels.py and of ``modules`` (what a cached kernel compiles in)."""
    text = "".join(inspect.getsource(m) for m in (law_kernels, *modules))
    return int(hashlib.sha256(text.encode()).hexdigest()[:15], 16)
