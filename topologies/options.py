"""A topology's options: the pydantic model it declares (``options_model``), against which a
scenario's ``topology`` section and Mininet's ``--topo name,key=value`` are checked.

A testbed topology (:class:`topologies.base.TestbedTopo`) declares its model as the class attribute
``options_model``; its ``build`` takes the model's fields as keyword arguments, already validated.
A plain Mininet ``Topo`` of a custom file (``topology.custom``) declares nothing: its model is made
from ``build``'s keyword arguments (their annotations, else the type of their defaults).
"""

from __future__ import annotations

import inspect
import typing
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, create_model


class TopologyOptions(BaseModel):
    """Base of every topology's options: unknown keys and NaN/inf refused, as in the scenario file."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, arbitrary_types_allowed=True)


class ClusteredOptions(TopologyOptions):
    """``clusters`` × ``turbines`` turbine hosts ``wt<c>_<n>`` (addresses: topologies.base)."""

    clusters: int = Field(5, ge=1, le=50, description=(
        "turbine clusters (the paper's farm has 5); at most 50, far within the 254 of the addressing"))
    turbines: int = Field(2, ge=1, le=100, description="turbines per cluster")


def options_of(topo_class: type) -> type[BaseModel]:
    """The options model of ``topo_class``: its ``options_model``, or one made from its ``build``'s
    keyword arguments (a plain Mininet ``Topo``)."""
    declared = getattr(topo_class, "options_model", None)
    if declared is not None:
        return declared
    build = topo_class.build
    try:
        hints = typing.get_type_hints(build)
    except Exception:  # noqa: BLE001 - a custom file's annotations may not resolve: take the defaults' types
        hints = {}
    fields: dict[str, Any] = {}
    for param in list(inspect.signature(build).parameters.values())[1:]:  # (self)
        if param.kind in (param.VAR_POSITIONAL, param.VAR_KEYWORD):
            continue
        default = ... if param.default is param.empty else param.default
        kind = hints.get(param.name, type(default) if default not in (..., None) else Any)
        fields[param.name] = (kind, default)
    return create_model(f"{topo_class.__name__}Options", __base__=TopologyOptions, **fields)


def described_options(topo_class: type) -> str:
    """``key (default)`` of every option, for messages."""
    model = options_of(topo_class)
    return ", ".join(f"{name} ({info.default!r})" if not info.is_required() else name
                     for name, info in model.model_fields.items()) or "none"
