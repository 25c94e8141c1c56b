"""What a control law of the SDC is: its parameters (declared once, with unit, source and whether a
REQUEST may change them while it runs), its state, its right-hand side and how it is discretised.

A law's parameters are a frozen dataclass whose fields are made with :func:`param`; a run-time
parameter must be one of the wire's run-time words (:data:`sdvisc.wire_layouts.RUNTIME_PARAM_WORDS`:
its ``mask`` bit, its REQUEST word and its accepted range are declared there) in the same unit —
``tests/unit/test_law_registry.py`` checks every law of :data:`sdc_unit.laws.LAWS` against it.

The right-hand side has the signature of :func:`sdc_unit.law_kernels.law_rhs`: ``rhs(x, m, c, dx,
out)`` with ``x`` the state rows, ``m`` the measurement rows (:data:`sdvisc.vocabulary.MEAS_FIELDS`),
``c`` the parameter rows (``Law.param_rows``), ``dx`` the derivatives and ``out`` the output rows
(``Law.out_rows``, beginning with :data:`LAW_OUTPUTS`) written in place; arithmetic and numpy ufuncs
only, so that it runs on rows of N turbines (numpy) and compiles for one turbine (numba).
Dependencies: numpy.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import MISSING, dataclass, field, fields
from typing import Any

import numpy as np

LAW_OUTPUTS = ("v_ref_d", "v_ref_q", "i_ref_d", "i_ref_q", "omega", "e_mag", "limited")
"""The outputs every law's ``rhs`` writes first, in this order (the CTRL words but delta, which is a
state, and the limiter flag as 0.0/1.0)."""


def param(default: float, unit: str = "", source: str = "", runtime: bool = False) -> Any:
    """A law parameter: a dataclass field with its ``default``, ``unit`` (p.u. on the turbine rating,
    s, ...), ``source`` (a citation, or the reason for the value) and ``runtime`` (a REQUEST may set it
    while the law runs: its name is then a wire run-time word)."""
    return field(default=default, metadata={"unit": unit, "source": source, "runtime": runtime})


@dataclass(frozen=True)
class ParamDeclaration:
    """One declared parameter of a law (read from its dataclass field)."""

    name: str
    default: Any
    unit: str
    source: str
    runtime: bool


def declarations(params_type: type) -> tuple[ParamDeclaration, ...]:
    """The parameters of a law's parameter dataclass as declared (fields without :func:`param` metadata
    count as not run-time, unit and source unknown)."""
    out = []
    for f in fields(params_type):
        meta = f.metadata
        default = f.default if f.default is not MISSING else None
        out.append(ParamDeclaration(f.name, default, meta.get("unit", ""), meta.get("source", ""),
                                    bool(meta.get("runtime", False))))
    return tuple(out)


def runtime_names(params_type: type) -> tuple[str, ...]:
    """Names of a law's run-time parameters, in declaration order."""
    return tuple(d.name for d in declarations(params_type) if d.runtime)


@dataclass(frozen=True)
class Law:
    """A control law the SDC can run.

    name: its registry key (``sdc.law`` in a scenario).
    params_type: its parameter dataclass (fields made with :func:`param`).
    state_names: the rows of its state (empty: a law without state).
    out_rows: the rows of ``rhs``'s outputs (beginning with :data:`LAW_OUTPUTS`).
    rhs: the right-hand side (module docstring), or None for a law without dynamics.
    param_row_names: the parameters ``rhs`` reads as ``c``, in row order (attributes of a
        ``params_type`` instance, properties such as ``omega0`` included; flags read as 0.0/1.0).
    initial_state: ``(meas rows, params) -> x``: the state at the operating point the measurements
        show (bumpless start: the first output is the converter voltage the turbine applies).
    bank: ``(n, step_s, method, dtype) -> controllers`` for the SDC's ControllerBank (the interface of
        :class:`sdc_unit.discrete.DiscreteVisc` it uses, listed in :mod:`sdc_unit.law_trapezoid`).
    methods: the discretisations ``bank`` accepts (empty: any, nothing to discretise).
    """

    name: str
    params_type: type
    state_names: tuple[str, ...] = ()
    out_rows: tuple[str, ...] = LAW_OUTPUTS
    rhs: Callable | None = None
    param_row_names: tuple[str, ...] = ()
    initial_state: Callable[[np.ndarray, Any], np.ndarray] | None = None
    bank: Callable[..., Any] | None = None
    methods: tuple[str, ...] = ()

    @property
    def runtime_params(self) -> tuple[str, ...]:
        return runtime_names(self.params_type)

    def declarations(self) -> tuple[ParamDeclaration, ...]:
        return declarations(self.params_type)

    def param_rows(self, params) -> np.ndarray:
        """The ``c`` rows of ``params`` (float64; a field may be an array of one value per turbine)."""
        return np.array([np.asarray(getattr(params, name), dtype=float) for name in self.param_row_names])
