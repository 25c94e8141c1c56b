"""The testbed's shared words, each written once: what a measurement and a control output are made
of, the ViSC parameters a request can set, turbine names, and the constants every model uses.

The wire layouts (:data:`sdvisc.wire.LAYOUTS`) are the source: the tuples here are read from them,
so a field added to a message appears everywhere it is used. Import from here, never repeat a list.
"""

from __future__ import annotations

import math

from sdvisc.wire import LAYOUTS, MsgType, ParamMask
from sdvisc.wire_layouts import RUNTIME_PARAM_WORDS

MEAS_FIELDS: tuple[str, ...] = tuple(f.name for f in LAYOUTS[MsgType.MEAS] if f.kind == "f32" and f.name != "t_sim")
"""What a turbine measures, in wire order: ``v_d, v_q, i_d, i_q, p, q, v_dc, omega_meas`` (p.u.)."""

CTRL_OUTPUTS: tuple[str, ...] = tuple(f.name for f in LAYOUTS[MsgType.CTRL] if f.kind == "f32")
"""What a controller answers, in wire order: ``v_ref_d, v_ref_q, i_ref_d, i_ref_q, delta, omega, e_mag``."""

REMOTE_REFERENCES: tuple[str, ...] = ("v_ref_d", "v_ref_q", "i_ref_d", "i_ref_q")
"""The part of a control output a remote turbine applies (voltage or current reference)."""

VISC_PARAMS: dict[str, int] = {m.name.lower(): int(m) for m in ParamMask}
"""ViSC parameters a REQUEST can set, by name, with their ``mask`` bit: h, d, m_q, v_ref, q_ref, supp."""

REQUEST_PARAM_WORDS: tuple[str, ...] = ("mask", *VISC_PARAMS)
"""The REQUEST words that carry parameters (the mask, then each parameter)."""

PARAM_LIMITS: dict[str, tuple[float, float]] = {p.name: (p.lo, p.hi) for p in RUNTIME_PARAM_WORDS if p.lo is not None}
"""Accepted range of each run-time parameter a REQUEST can set (bit fields such as ``supp``: any value)."""

PARAM_UNITS: dict[str, str] = {p.name: p.unit for p in RUNTIME_PARAM_WORDS}
"""Unit of each run-time parameter word (a law's run-time parameter must be declared in the same unit)."""

BLANK_REQUEST_PARAMS: dict[str, float | int] = {"mask": 0, **{p.name: 0 if p.kind == "i32" else 0.0
                                                             for p in RUNTIME_PARAM_WORDS}}
"""The parameter words of a REQUEST that sets none (mask 0, every word zero): copy it, then set."""


def param_word(name: str, value) -> float | int:
    """``value`` as the REQUEST word ``name`` carries it (int for an i32 word such as ``supp``)."""
    return int(value) if BLANK_REQUEST_PARAMS[name].__class__ is int else float(value)

TURBINE_PATTERN = r"^wt[1-9]\d*_[1-9]\d?$"
"""A turbine name: ``wt<cluster>_<number>`` (cluster ≥ 1, number 1–99); see :func:`sdvisc.wire.parse_turbine`."""

ONSHORE_CLUSTER = 6
"""The cluster number in the names of the plant's onshore units (``PlantParams.onshore_units``, the
aggregated 40 MVA SDViSC of the paper's comparison arrangement at the onshore PCC): unit k is host
``wt6_<k>`` (wire id 600 + k), the group after the full farm's five clusters of ten, so that the
farm's index rule (c − 1)·10 + n − 1 gives 50 + k − 1: the converters the plant appends after its 50
turbines (``plant.cases.COMPARISON_UNIT`` = 50 for ``wt6_1``)."""
MAX_ONSHORE_UNITS = 10
"""At most this many onshore units (``wt6_1`` … ``wt6_10``: the index rule's group of ten)."""


def onshore_host(unit: int) -> str:
    """Host name of onshore unit ``unit`` (from 1): ``wt6_<unit>``."""
    if not 1 <= unit <= MAX_ONSHORE_UNITS:
        raise ValueError(f"onshore unit {unit}: must be within 1..{MAX_ONSHORE_UNITS}")
    return f"wt{ONSHORE_CLUSTER}_{unit}"


PLANT_TURBINES_PER_CLUSTER = 10
"""Turbines per cluster of the full plant model (plant/params.py: 5 clusters, 50 turbines; the
paper's farm)."""


def plant_index(cluster: int, number: int) -> int:
    """The full plant model's converter of turbine host ``wt<cluster>_<number>`` (both from 1):
    ``(cluster-1)*10 + number-1``, the one place of this rule. It runs on past the farm's 50
    turbines: onshore unit k (host ``wt6_<k>``) is converter 50 + k - 1, after the farm's
    (``PlantParams.onshore_units``). A topology writes it into each turbine's host entry
    (``topologies.base.describe``, ``plant_index``), which the processes read."""
    return (cluster - 1) * PLANT_TURBINES_PER_CLUSTER + number - 1

F_NOMINAL_HZ = 50.0
"""Nominal grid frequency, Hz."""
OMEGA0 = 2.0 * math.pi * F_NOMINAL_HZ
"""Nominal angular frequency, rad/s."""

FILTER_R_F_PU = 0.003
"""Grid-side filter resistance of a turbine's converter, p.u. on the turbine rating."""
FILTER_X_F_PU = 0.08
"""Grid-side filter reactance (ω0·L_f) of a turbine's converter, p.u. on the turbine rating."""


def params_from_mask(values: dict) -> dict[str, float]:
    """The ViSC parameters a REQUEST marks as meaningful (``mask`` bits), by name."""
    mask = int(values.get("mask", 0))
    return {name: values[name] for name, bit in VISC_PARAMS.items() if mask & bit}


def mask_of(params: dict) -> int:
    """The ``mask`` word for a dict of parameters by name (unknown names raise KeyError)."""
    mask = 0
    for name in params:
        mask |= VISC_PARAMS[name]
    return mask
