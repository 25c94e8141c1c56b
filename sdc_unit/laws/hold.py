"""The "hold" law: network only, no dynamics. The bank answers every measurement with the converter
voltage of the operating point it saw first (``v + (R_f + jX_f)·i``), so packets flow with realistic
sizes and timing at negligible CPU cost (sdc_unit.bank)."""

from __future__ import annotations

from dataclasses import dataclass

from sdc_unit.law_spec import Law


@dataclass(frozen=True)
class HoldParams:
    """No parameters."""


LAW = Law(name="hold", params_type=HoldParams, methods=("hold",))
