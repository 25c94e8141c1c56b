"""The SDC's control laws, by name: a new law is one module here (its parameters declared with
:func:`sdc_unit.law_spec.param`, its ``rhs``, initial state and bank, see :class:`sdc_unit.law_spec.Law`)
and one line below. A scenario chooses one with ``sdc.law``; the discretisation with ``sdc.method``
(one of the law's ``methods``). docs/architecture.md "Extending the testbed" has the worked example."""

from __future__ import annotations

from sdc_unit.law_spec import Law
from sdc_unit.laws import droop, hold, visc

LAWS: dict[str, Law] = {
    "visc": visc.LAW,
    "hold": hold.LAW,
    "droop": droop.LAW,
}


def get_law(name: str) -> Law:
    """The law ``name`` (ValueError naming the known ones otherwise)."""
    try:
        return LAWS[name]
    except KeyError:
        raise ValueError(f"unknown SDC law {name!r}; known: {', '.join(LAWS)}") from None
