"""A faulty card, on purpose: bad datagrams the emulated GTNET-SKT card (:mod:`plant.card.core`)
sends toward its SDC when its configuration asks for them (``misbehave``), so that a run can check
that the testbed rejects and counts bad input from an external device and that the other turbines'
control goes on (issue 29, 4c). Pure: the datagrams are built here, the core sends them.

Kinds (each ``count`` datagrams from the named turbine's port, in the step at ``t_s``):

- ``wrong_word_count``: the turbine's MEAS with one word too many (a card configured with another point list);
- ``unknown_turbine``: a well-formed MEAS for a turbine id nobody serves (``UNKNOWN_WID``);
- ``flood``: copies of a well-formed MEAS of the turbine in one burst (a card stuck in a send loop).
"""

from __future__ import annotations

import struct
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from sdvisc import wire
from sdvisc.config import TurbineName
from sdvisc.vocabulary import MEAS_FIELDS

UNKNOWN_WID = wire.turbine_id(49, 99)
"""A well-formed turbine id (wt49_99) that no scenario's card or plant serves."""


class Misbehaviour(BaseModel):
    """One burst of bad datagrams (see the module docstring)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    t_s: float = Field(ge=0, description="card time of the burst, s from the card's start")
    turbine: TurbineName = Field(description="the port (turbine) it leaves from")
    kind: Literal["wrong_word_count", "unknown_turbine", "flood"]
    count: int = Field(1, ge=1, le=100_000, description="datagrams in the burst")


def bad_datagrams(kind: str, count: int, wid: int, seq: int, t_sim: float, header: bool) -> list[bytes]:
    """``count`` datagrams of ``kind`` for turbine ``wid`` (``seq``: its MEAS counter now)."""
    values = {"wt": UNKNOWN_WID if kind == "unknown_turbine" else wid, "seq": seq, "t_sim": t_sim,
              **dict.fromkeys(MEAS_FIELDS, 0.0)}
    hdr = wire.Header(seq & wire.UINT32_MAX, 0, 0) if header else None
    data = wire.encode(wire.MsgType.MEAS, values, header=hdr)
    if kind == "wrong_word_count":
        data += struct.pack(">i", 0)
    return [data] * count
