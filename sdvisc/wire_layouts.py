"""The message layouts of the SDViSC testbed and the addresses its words carry, declared once:
ports, value limits, the enums, :data:`LAYOUTS` (which 4-byte word of each message means what, with
its unit) and the turbine-id / IPv4 conversions. The codec is :mod:`sdvisc.wire`, which re-exports
every name here; ``docs/wire-format.md`` has the reference tables."""

from __future__ import annotations

import enum
import ipaddress
import re
from dataclasses import dataclass
from typing import Literal

MAX_WORDS = 300
"""Largest GTNET-SKT packet, in 4-byte words (1200 bytes)."""

WORD_BYTES = 4
HEADER_WORDS = 3
"""Words in the VILLASnode fake header (seq, sec, nsec)."""

PORT_CONTROLLER = 50000
"""SDN app (virtual controller IP): receives AK, REQUEST (from OWFCC), REPLY (from SDC), HEARTBEAT."""
PORT_SDC = 50010
"""SDC: receives MEAS and REQUEST (commands)."""
PORT_TURBINE = 50020
"""Turbine endpoint: receives CTRL and REQUEST (stream start/stop)."""
PORT_OWFCC = 50030
"""Offshore wind-farm central controller: receives REPLY."""

PORT_ROLES: dict[int, str] = {
    PORT_CONTROLLER: "controller",
    PORT_SDC: "sdc",
    PORT_TURBINE: "turbine",
    PORT_OWFCC: "owfcc",
}
"""Every UDP port the testbed uses, with the role listening on it."""

INT32_MIN = -(2**31)
INT32_MAX = 2**31 - 1
UINT32_MAX = 2**32 - 1
FLOAT32_MAX = 3.4028234663852886e38

RejectReason = Literal["length", "type", "nonfinite", "range", "field"]
REJECT_REASONS: tuple[str, ...] = ("length", "type", "nonfinite", "range", "field")


class MsgType(enum.IntEnum):
    """Value of word 0 (``msg_type``) of every message."""

    MEAS = 1
    CTRL = 2
    AK = 3
    REQUEST = 4
    REPLY = 5
    HEARTBEAT = 6


class Command(enum.IntEnum):
    """``REQUEST.cmd``: what the requester asks for."""

    VISC_ON = 1
    VISC_OFF = 2
    SET_PARAMS = 3
    TAKEOVER = 4
    START_INSTANCE = 5
    STOP_INSTANCE = 6
    STREAM_START = 7
    STREAM_STOP = 8


class Status(enum.IntEnum):
    """``REPLY.status``: outcome of a request."""

    OK = 0
    UNKNOWN_TURBINE = 1
    NOT_ENABLED = 2
    NO_PATH = 3
    COMM_OFF = 4
    BAD_REQUEST = 5
    BUSY = 6
    REFUSED = 7


@dataclass(frozen=True)
class RuntimeParam:
    """One run-time parameter word of a REQUEST: what a law may change while it runs (START_INSTANCE,
    SET_PARAMS). Declared once here: the ``mask`` bits (:class:`ParamMask`), the REQUEST's words, the
    admission's accepted range (:mod:`sdc_unit.admission`), the schema's and the OWFCC's parameter
    names are generated from :data:`RUNTIME_PARAM_WORDS`. A law (``sdc_unit.laws``) marks which of its
    parameters are run-time ones by these names; ``tests/unit/test_law_registry.py`` fails if a law
    and this list disagree (name or unit)."""

    name: str
    kind: Literal["i32", "f32"]
    unit: str
    doc: str
    lo: float | None = None
    hi: float | None = None
    """Accepted range (None: any value of the kind is valid, e.g. a bit field)."""


RUNTIME_PARAM_WORDS: tuple[RuntimeParam, ...] = (
    RuntimeParam("h", "f32", "s", "inertia constant H", 1e-3, 100.0),
    RuntimeParam("d", "f32", "p.u.", "damping D", 0.0, 1e4),
    RuntimeParam("m_q", "f32", "p.u.", "reactive-power droop m_q", 0.0, 10.0),
    RuntimeParam("v_ref", "f32", "p.u.", "voltage reference", 0.5, 1.5),
    RuntimeParam("q_ref", "f32", "p.u.", "reactive-power reference", -10.0, 10.0),
    RuntimeParam("supp", "i32", "", "supplementary-control bit field"),
)
"""The REQUEST's parameter words in wire order; the ``mask`` bit of the k-th is 2**k. Ranges as the
SDC admits them (h: above 0 and at most 100 s; d: at most 1e4 p.u.; m_q: at most 10 p.u.; v_ref:
0.5-1.5 p.u. as a converter can hold; q_ref: ±10 p.u.)."""

ParamMask = enum.IntFlag("ParamMask", [(p.name.upper(), 1 << k) for k, p in enumerate(RUNTIME_PARAM_WORDS)],
                         module=__name__)
ParamMask.__doc__ = """``REQUEST.mask``: which parameter words of a REQUEST are meaningful (H = 1, D = 2,
M_Q = 4, V_REF = 8, Q_REF = 16, SUPP = 32: generated from :data:`RUNTIME_PARAM_WORDS`)."""


@dataclass(frozen=True)
class Field:
    """One 4-byte word of a message layout."""

    name: str
    kind: Literal["i32", "f32"]
    unit: str
    doc: str
    enum: type[enum.IntEnum] | None = None


def _i32(name: str, doc: str, unit: str = "", enum_type: type[enum.IntEnum] | None = None) -> Field:
    return Field(name, "i32", unit, doc, enum_type)


def _f32(name: str, unit: str, doc: str) -> Field:
    return Field(name, "f32", unit, doc)


MSG_TYPE_FIELD = _i32("msg_type", "message type", enum_type=MsgType)

LAYOUTS: dict[MsgType, tuple[Field, ...]] = {
    MsgType.MEAS: (
        MSG_TYPE_FIELD,
        _i32("wt", "turbine id (cluster*100 + number)"),
        _i32("seq", "plant sample counter for this turbine"),
        _f32("t_sim", "s", "plant simulation time of the sample"),
        _f32("v_d", "p.u.", "terminal voltage, d axis of the common synchronous frame"),
        _f32("v_q", "p.u.", "terminal voltage, q axis of the common synchronous frame"),
        _f32("i_d", "p.u.", "converter current, d axis of the common frame"),
        _f32("i_q", "p.u.", "converter current, q axis of the common frame"),
        _f32("p", "p.u.", "active power on turbine rating, generator convention"),
        _f32("q", "p.u.", "reactive power on turbine rating, generator convention"),
        _f32("v_dc", "p.u.", "DC-link voltage"),
        _f32("omega_meas", "p.u.", "frequency measured by the turbine PLL"),
    ),
    MsgType.CTRL: (
        MSG_TYPE_FIELD,
        _i32("wt", "turbine id (cluster*100 + number)"),
        _i32("seq", "SDC's own CTRL counter for this turbine"),
        _i32("meas_seq", "the MEAS seq this CTRL answers"),
        _f32("v_ref_d", "p.u.", "converter voltage reference applied by the converter, d axis (common frame)"),
        _f32("v_ref_q", "p.u.", "converter voltage reference applied by the converter, q axis (common frame)"),
        _f32("i_ref_d", "p.u.", "current reference after the limiter, d axis"),
        _f32("i_ref_q", "p.u.", "current reference after the limiter, q axis"),
        _f32("delta", "rad", "virtual rotor angle versus the common frame"),
        _f32("omega", "p.u.", "virtual rotor speed"),
        _f32("e_mag", "p.u.", "internal EMF magnitude"),
        _i32("flags", "bit field: bit0 current limiter active, bit1 backup SDC output"),
    ),
    MsgType.AK: (
        MSG_TYPE_FIELD,
        _i32("wt", "turbine id (cluster*100 + number)"),
        _i32("seq", "AK counter of this turbine"),
        _i32("ak", "1 = CTRL packets arriving, 0 = not"),
        _i32("ctrl_rx", "CTRL packets received so far"),
        _f32("ctrl_age_ms", "ms", "time since the last CTRL arrived, capped at 1e6"),
    ),
    MsgType.REQUEST: (
        MSG_TYPE_FIELD,
        _i32("req_id", "request id, echoed in the REPLY"),
        _i32("cmd", "requested command", enum_type=Command),
        _i32("wt", "turbine id (cluster*100 + number)"),
        _i32("sdc_ip", "IPv4 address of the SDC, two's-complement int32", unit="IPv4"),
        _i32("mask", "ParamMask bits: which of the parameters below are meaningful"),
        *(Field(p.name, p.kind, p.unit, p.doc) for p in RUNTIME_PARAM_WORDS),
    ),
    MsgType.REPLY: (
        MSG_TYPE_FIELD,
        _i32("req_id", "id of the REQUEST answered"),
        _i32("status", "outcome", enum_type=Status),
        _i32("wt", "turbine id (cluster*100 + number)"),
        _i32("cmd", "the command answered", enum_type=Command),
        _i32("detail", "free detail code, 0 if none"),
    ),
    MsgType.HEARTBEAT: (
        MSG_TYPE_FIELD,
        _i32("sdc_id", "id of the SDC sending the heartbeat"),
        _i32("seq", "heartbeat counter"),
        _i32("n_instances", "SDC instances currently running"),
        _f32("t_wall", "s", "wall-clock seconds modulo 1e4"),
    ),
}


def ip_to_i32(ip: str) -> int:
    """IPv4 dotted quad as the signed int32 carried in one word (two's complement)."""
    value = int(ipaddress.IPv4Address(ip))
    return value - 2**32 if value > INT32_MAX else value


def i32_to_ip(v: int) -> str:
    """Inverse of :func:`ip_to_i32`."""
    if not INT32_MIN <= v <= INT32_MAX:
        raise ValueError(f"{v} is not an int32")
    return str(ipaddress.IPv4Address(v & UINT32_MAX))


_TURBINE_NAME = re.compile(r"wt([1-9]\d*)_([1-9]\d?)")


def turbine_id(cluster: int, number: int) -> int:
    """Turbine id carried in ``wt`` words: ``cluster*100 + number`` (wt1_1 -> 101)."""
    if cluster < 1 or not 1 <= number <= 99:
        raise ValueError(f"no turbine wt{cluster}_{number}: cluster >= 1 and 1 <= number <= 99")
    return cluster * 100 + number


def is_turbine_id(wid: int) -> bool:
    """True if ``wid`` is a turbine id as carried in ``wt`` words (cluster ≥ 1, number 1–99)."""
    cluster, number = divmod(wid, 100)
    return cluster >= 1 and number >= 1


def turbine_name(wid: int) -> str:
    """Turbine name for an id (101 -> "wt1_1"); ValueError if it is none (see :func:`is_turbine_id`)."""
    if not is_turbine_id(wid):
        raise ValueError(f"{wid} is not a turbine id")
    cluster, number = divmod(wid, 100)
    return f"wt{cluster}_{number}"


def parse_turbine(name: str) -> tuple[int, int]:
    """(cluster, number) of a turbine name ("wt1_10" -> (1, 10)); ValueError otherwise."""
    match = _TURBINE_NAME.fullmatch(name)
    if match is None:
        raise ValueError(f"{name!r} is not a turbine name like 'wt1_10'")
    return int(match.group(1)), int(match.group(2))
