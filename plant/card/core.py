"""The project's GTNET-SKT card emulator (an RTDS with GTNET-SKT cards, emulated), as pure code: its
configuration and its decisions — datagrams and ``now`` in; datagrams and counters out.

Nothing here opens a socket, sleeps, reads a clock or writes a file: :meth:`CardCore.receive` takes
one datagram that arrived on a turbine's port with ``now`` (the card clock's reading, s) and
:meth:`CardCore.step` returns the datagrams to send. The socket shim and ``main`` are in
:mod:`plant.card` (as :mod:`plant.service` is the shim of :mod:`plant.service.core`).

Each turbine is one UDP port on the card's IP: its MEAS and AK leave from that port, its CTRL and
commands arrive on it. The turbines are a :class:`plant.minimal.MinimalPlant`. Admission follows the
plant's rules (:mod:`plant.service.endpoint_rx`): a ``REQUEST`` (``STREAM_START``/``STREAM_STOP``) only from
the SDN app's virtual IP; a ``CTRL`` only from the SDC named by ``STREAM_START`` or the card's fixed
remote (``sdc``), for the turbine of its port, answering a MEAS already sent, with plausible
references; a duplicate or overtaken ``CTRL`` is ``ctrl_stale``. Everything else is dropped and
counted per turbine port under one reason (:data:`REASONS`); nothing raises.
"""

from __future__ import annotations

import copy
import ipaddress
import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from pydantic import BaseModel, Field, field_validator, model_validator

from plant.card.faults import Misbehaviour, bad_datagrams
from plant.minimal import MinimalPlant
from plant.service.core import CTRL_GAP_STEPS, MAX_CTRL_GAPS
from plant.service.endpoint_rx import MAX_REF_PU, TURBINE_COMMANDS, is_unicast_word
from plant.service.endpoint_tx import MeasPacker
from sdvisc import wire
from sdvisc.config import (
    CONTROLLER_VIP,
    ClockSettings,
    FallbackSeconds,
    ImpairNodeConfig,
    OutputDir,
    PlantOptions,
    RunSeconds,
    StepSeconds,
    TurbineName,
)
from sdvisc.vocabulary import MEAS_FIELDS

REASONS: tuple[str, ...] = wire.REJECT_REASONS + (
    "flood", "unexpected_type", "unknown_turbine", "wrong_turbine", "not_from_controller", "bad_request",
    "not_from_sdc", "future_seq", "out_of_range", "internal")
"""Why a datagram was dropped: the wire's reasons (``length`` = wrong word count or size, ``type`` =
unknown msg_type, ``nonfinite``, ``range``, ``field``), ``flood`` (beyond ``flood_limit_per_step`` on
its port in one step, not decoded), ``unexpected_type`` (not CTRL/REQUEST), ``unknown_turbine`` (a
``wt`` no port of the card has), ``wrong_turbine`` (another port's turbine), ``not_from_controller``,
``bad_request``, ``not_from_sdc``, ``future_seq``, ``out_of_range`` (as :mod:`plant.service.endpoint_rx`),
``internal`` (handling it raised: a bug, counted, the card goes on)."""

COUNTERS = ("meas_tx", "ctrl_rx", "ctrl_stale", "ak_tx", "ak_ones", "commands_rx", "tx_error", "meas_unencodable",
            "socket_error")
"""Per turbine port: MEAS and AK sent (``ak_ones``: AKs saying 1), CTRL applied, CTRL stale (a duplicate
or overtaken answer, not a rejection), commands (STREAM_START/STOP) carried out, datagrams the
socket refused (``tx_error``, not in meas_tx/ak_tx), MEAS the wire cannot carry, receive errors."""


class _Strict(BaseModel):
    model_config = ClockSettings.model_config  # as every sdvisc.config model: unknown keys, NaN/Inf refused


def _same_as(model, name: str):
    """The field ``name`` of another config model: one definition of its bounds and default."""
    return copy.copy(model.model_fields[name])


class CardTurbine(_Strict):
    """One turbine of the card: its name, wire id and UDP port on the card's IP."""

    name: TurbineName
    wid: int = Field(ge=101, description="turbine id in wt words (cluster*100 + number)")
    port: int = Field(ge=1, le=65535, description="the turbine's UDP port on the card (sends and receives)")

    @model_validator(mode="after")
    def _wid_is_the_names(self):
        expected = wire.turbine_id(*wire.parse_turbine(self.name))
        if self.wid != expected:
            raise ValueError(f"wid {self.wid} is not {self.name}'s id ({expected})")
        return self


class RemoteAddress(_Strict):
    """The card's fixed remote (a real card's configured remote IP and port)."""

    ip: str = Field(description="IPv4 address of the SDC the card sends to")
    port: int = Field(wire.PORT_SDC, ge=1, le=65535, description="its UDP port")

    @field_validator("ip")
    @classmethod
    def _ipv4(cls, value: str) -> str:
        ipaddress.IPv4Address(value)
        return value


class GtnetCardConfig(ClockSettings, OutputDir):
    """``python -m plant.card.emulator --config FILE`` (YAML or JSON)."""

    step_s: StepSeconds
    bind_ip: str = Field("0.0.0.0", description="the card's IP address: every turbine port is bound to it")
    framing: Literal["native", "villas"] = Field("native", description=(
        "native: exactly the configured words, no header (a real card); villas: VILLASnode's fake header "
        "(seq, sec, nsec) first, as the testbed runs"))
    controller_vip: str = Field(CONTROLLER_VIP, description="the SDN app's virtual IP: AKs go to it, requests "
                                "come from it")
    controller_port: int = Field(wire.PORT_CONTROLLER, ge=1, le=65535, description="the UDP port AKs go to")
    turbines: list[CardTurbine] = Field(min_length=1, description="one UDP port per turbine")
    sdc: RemoteAddress | None = Field(None, description="fixed remote: MEAS go here until a STREAM_START names an SDC")
    stream: Literal["on_request", "always"] = Field("on_request", description=(
        "on_request: MEAS only after STREAM_START (to the SDC it names); always: from t = 0 to the fixed remote"))
    check_rx_source: bool = Field(True, description="CTRL only from the SDC/fixed remote, REQUEST only from the VIP")
    ak_period_s: float = _same_as(PlantOptions, "ak_period_s")
    ak_window_s: float = _same_as(PlantOptions, "ak_window_s")
    remote_loss_fallback_s: FallbackSeconds
    duration_s: RunSeconds = None
    flood_limit_per_step: int = Field(32, ge=1, le=100_000, description=(
        "datagrams one port takes per step; the rest of that step's arrivals are dropped (flood)"))
    spin_us: float = _same_as(ImpairNodeConfig, "spin_us")
    misbehave: list[Misbehaviour] = Field(default_factory=list, description=(
        "bursts of bad datagrams toward the SDC, on purpose (plant.card.faults): a faulty card"))

    @field_validator("bind_ip", "controller_vip")
    @classmethod
    def _ipv4(cls, value: str) -> str:
        ipaddress.IPv4Address(value)
        return value

    @field_validator("turbines")
    @classmethod
    def _distinct(cls, turbines: list[CardTurbine]) -> list[CardTurbine]:
        for key in ("name", "wid", "port"):
            values = [getattr(t, key) for t in turbines]
            twice = sorted({v for v in values if values.count(v) > 1}, key=str)
            if twice:
                raise ValueError(f"two turbines with the same {key}: {twice}")
        return turbines

    @model_validator(mode="after")
    def _always_needs_a_remote(self):
        if self.stream == "always" and self.sdc is None:
            raise ValueError("stream 'always' needs a fixed remote: set sdc (ip, port)")
        return self

    @property
    def header(self) -> bool:
        """Whether datagrams carry the VILLAS header."""
        return self.framing == "villas"


@dataclass
class CardPort:
    """One turbine's port on the card and its counters (no socket: the shim holds it)."""

    name: str
    wid: int
    port: int
    index: int
    streaming: bool = False
    sdc_addr: tuple[str, int] | None = None  # where its MEAS go
    named_sdc_ip: str | None = None  # the SDC named by the last STREAM_START
    meas_seq: int = 0
    ak_seq: int = 0
    ctrl_seq: int = -1  # the MEAS seq the newest applied CTRL answered
    last_ctrl_t: float = float("-inf")
    last_ak_sent: int = -1
    arrivals: int = 0  # datagrams taken in the current step
    counts: dict = field(default_factory=lambda: dict.fromkeys(COUNTERS, 0))
    rejected: dict = field(default_factory=dict)
    first_meas_tx_t: float | None = None  # card time (k * step_s) of the first MEAS
    first_ctrl_rx_t: float | None = None  # ... of the first and the last CTRL applied
    last_ctrl_rx_t: float | None = None
    ctrl_gaps: list = field(default_factory=list)  # (clock before, clock after) pauses between CTRLs > CTRL_GAP_STEPS
    misbehaved_tx: int = 0  # bad datagrams sent on purpose (misbehave)


class CardCore:
    """The card's turbines; see the module docstring. ``model``: a MinimalPlant to use (default: one
    built from ``cfg``)."""

    def __init__(self, cfg: GtnetCardConfig, model: MinimalPlant | None = None) -> None:
        self.cfg = cfg
        self.step_s = cfg.step_s
        self.n_steps = int(round(cfg.duration_s / cfg.step_s)) if cfg.duration_s is not None else None
        self.header = cfg.header
        self.ak_addr = (cfg.controller_vip, cfg.controller_port)
        self.ak_every = max(1, int(round(cfg.ak_period_s / cfg.step_s)))
        self.model = model if model is not None else MinimalPlant(
            len(cfg.turbines), cfg.step_s, remote_loss_fallback_s=cfg.remote_loss_fallback_s)
        self.fixed = (cfg.sdc.ip, cfg.sdc.port) if cfg.sdc is not None else None
        self.always = cfg.stream == "always"
        self.ports = [CardPort(t.name, t.wid, t.port, i, streaming=self.always, sdc_addr=self.fixed)
                      for i, t in enumerate(cfg.turbines)]
        self.wids = {p.wid for p in self.ports}
        self.wire_stats = wire.DecodeStats()
        self.meas_packer = MeasPacker(self.header)
        self.k = 0
        self._newest: dict[int, tuple[float, float, float, float]] = {}  # model index -> newest refs this step
        self._remote_once: set[int] = set()  # "always": turbines whose first CTRL made them remote
        self.internal_error: str | None = None

    # ------------------------------------------------------------------ receive
    def _reject(self, port: CardPort, reason: str) -> None:
        port.rejected[reason] = port.rejected.get(reason, 0) + 1

    def receive(self, i: int, data: bytes, addr, now: float) -> None:
        """One datagram that arrived on port ``i`` (index in ``cfg.turbines``) from ``addr``; never
        raises: a datagram whose handling fails is counted as ``internal`` (the first error kept)."""
        port = self.ports[i]
        try:
            self._receive(port, data, addr, now)
        except Exception as error:  # bad input never stops the card
            self._reject(port, "internal")
            self.internal_error = self.internal_error or f"{type(error).__name__}: {error}"

    def _receive(self, port: CardPort, data: bytes, addr, now: float) -> None:
        port.arrivals += 1
        if port.arrivals > self.cfg.flood_limit_per_step:
            self._reject(port, "flood")
            return
        try:
            msg = wire.decode(data, header=self.header)
        except wire.WireError as error:
            setattr(self.wire_stats, error.reason, getattr(self.wire_stats, error.reason) + 1)
            self._reject(port, error.reason)
            return
        self.wire_stats.ok += 1
        if msg.type != wire.MsgType.CTRL and msg.type != wire.MsgType.REQUEST:
            return self._reject(port, "unexpected_type")
        wt = msg["wt"]
        if wt != port.wid:
            return self._reject(port, "wrong_turbine" if wt in self.wids else "unknown_turbine")
        if msg.type == wire.MsgType.REQUEST:
            return self._request(port, msg, addr)
        self._ctrl(port, msg, addr, now)

    def _request(self, port: CardPort, msg: wire.Message, addr) -> None:
        if self.cfg.check_rx_source and addr[0] != self.cfg.controller_vip:
            return self._reject(port, "not_from_controller")
        cmd, sdc_ip = msg["cmd"], msg["sdc_ip"]
        start = cmd == wire.Command.STREAM_START
        if cmd not in TURBINE_COMMANDS or (start and not is_unicast_word(sdc_ip) and (sdc_ip or not self.fixed)):
            return self._reject(port, "bad_request")
        port.counts["commands_rx"] += 1
        if start:  # sdc_ip 0: to the fixed remote; the fixed remote's IP: to its configured port
            port.named_sdc_ip = wire.i32_to_ip(sdc_ip) if sdc_ip else self.fixed[0]
            fixed_port = self.fixed[1] if self.fixed and self.fixed[0] == port.named_sdc_ip else None
            port.sdc_addr = (port.named_sdc_ip, fixed_port or wire.PORT_SDC)
            port.streaming = True
            self.model.set_mode(port.index, "remote")
        else:  # STREAM_STOP; a card streaming "always" goes on, to its fixed remote
            port.named_sdc_ip = None
            port.sdc_addr = self.fixed
            port.streaming = self.always
            self.model.set_mode(port.index, "grid_following")

    def _ctrl(self, port: CardPort, msg: wire.Message, addr, now: float) -> None:
        if self.cfg.check_rx_source and addr[0] not in (port.named_sdc_ip, self.fixed and self.fixed[0]):
            return self._reject(port, "not_from_sdc")
        v = msg.values
        meas_seq = v["meas_seq"]
        if meas_seq > port.meas_seq:
            return self._reject(port, "future_seq")
        if (math.hypot(v["v_ref_d"], v["v_ref_q"]) > MAX_REF_PU
                or math.hypot(v["i_ref_d"], v["i_ref_q"]) > MAX_REF_PU):
            return self._reject(port, "out_of_range")
        if meas_seq <= port.ctrl_seq:
            port.counts["ctrl_stale"] += 1
            return
        port.ctrl_seq = meas_seq
        port.counts["ctrl_rx"] += 1
        if port.last_ctrl_t > float("-inf") and now - port.last_ctrl_t > CTRL_GAP_STEPS * self.step_s \
                and len(port.ctrl_gaps) < MAX_CTRL_GAPS:
            port.ctrl_gaps.append((port.last_ctrl_t, now))
        port.last_ctrl_t = now
        port.last_ctrl_rx_t = self.k * self.step_s
        if port.first_ctrl_rx_t is None:
            port.first_ctrl_rx_t = port.last_ctrl_rx_t
        if self.always and port.index not in self._remote_once:  # no STREAM_START: the first answer
            self._remote_once.add(port.index)
            self.model.set_mode(port.index, "remote")
        self._newest[port.index] = (v["v_ref_d"], v["v_ref_q"], v["i_ref_d"], v["i_ref_q"])

    # ------------------------------------------------------------------ step
    def step(self, now: float) -> list[tuple[int, str, bytes, tuple[str, int]]]:
        """Apply each turbine's newest CTRL, advance the model one step and return the datagrams due:
        (port index, "meas" or "ak", datagram, destination) — every streaming turbine's MEAS, then the
        AKs due (every ``ak_period_s`` and whenever a turbine's AK changes)."""
        if self._newest:
            index = np.fromiter(self._newest, dtype=np.intp, count=len(self._newest))
            refs = np.array(list(self._newest.values()), dtype=np.float64).T.copy()
            self._newest = {}
            self.model.apply_remote(index, refs[0], refs[1], refs[2], refs[3])
        self.model.step()
        self.k += 1
        for port in self.ports:
            port.arrivals = 0
        streaming = [p for p in self.ports if p.streaming and p.sdc_addr is not None]
        bad = self._misbehave(streaming)
        if not streaming:
            return bad
        meas = self.model.measurements()
        columns = [meas[key] for key in MEAS_FIELDS]
        t_sim = self.k * self.step_s
        sec = int(now)
        nsec = min(int((now - sec) * 1e9), 999_999_999)
        periodic = self.k % self.ak_every == 0
        out: list = []
        aks: list = []
        for port in streaming:
            i = port.index
            port.meas_seq += 1
            data = self.meas_packer.pack(port.wid, port.meas_seq, t_sim, [float(c[i]) for c in columns], sec, nsec)
            if data is None:  # a value the wire cannot carry
                port.counts["meas_unencodable"] += 1
            else:
                port.counts["meas_tx"] += 1
                out.append((i, "meas", data, port.sdc_addr))
                if port.first_meas_tx_t is None:
                    port.first_meas_tx_t = t_sim
            ak = int(now - port.last_ctrl_t <= self.cfg.ak_window_s)
            if periodic or ak != port.last_ak_sent:
                aks.append((i, "ak", self._ak(port, ak, now, sec, nsec), self.ak_addr))
        return out + aks + bad

    def _misbehave(self, streaming: list[CardPort]) -> list:
        """The bursts of bad datagrams due in this step (``misbehave``), from streaming ports only."""
        due = [m for m in self.cfg.misbehave if round(m.t_s / self.step_s) == self.k]
        out = []
        for m in due:
            port = next((p for p in streaming if p.name == m.turbine), None)
            if port is None:
                continue
            for data in bad_datagrams(m.kind, m.count, port.wid, port.meas_seq, self.k * self.step_s, self.header):
                out.append((port.index, "bad", data, port.sdc_addr))
            port.misbehaved_tx += m.count
        return out

    def _ak(self, port: CardPort, ak: int, now: float, sec: int, nsec: int) -> bytes:
        port.ak_seq += 1
        port.last_ak_sent = ak
        port.counts["ak_tx"] += 1
        port.counts["ak_ones"] += ak
        values = {"wt": port.wid, "seq": port.ak_seq, "ak": ak, "ctrl_rx": port.counts["ctrl_rx"],
                  "ctrl_age_ms": min((now - port.last_ctrl_t) * 1e3, 1e6)}
        hdr = wire.Header(port.ak_seq & wire.UINT32_MAX, sec & wire.UINT32_MAX, nsec) if self.header else None
        return wire.encode(wire.MsgType.AK, values, header=hdr)

    def send_failed(self, i: int, kind: str) -> None:
        """The socket refused a datagram :meth:`step` returned: not counted as sent, but as ``tx_error``."""
        port = self.ports[i]
        if kind == "bad":
            port.misbehaved_tx -= 1
        else:
            port.counts["meas_tx" if kind == "meas" else "ak_tx"] -= 1
        port.counts["tx_error"] += 1

    def socket_error(self, i: int) -> None:
        """Port ``i``'s socket reported an error instead of a datagram."""
        self.ports[i].counts["socket_error"] += 1

    # ------------------------------------------------------------------ summary
    def summary(self) -> dict:
        """Per turbine and in total: what was sent, received and dropped (by reason)."""
        modes = self.model.mode
        turbines = {}
        for p in self.ports:
            turbines[p.name] = {
                "wid": p.wid, "port": p.port, "streaming": p.streaming,
                "sdc": f"{p.sdc_addr[0]}:{p.sdc_addr[1]}" if p.sdc_addr else None, **p.counts,
                "rejected": dict(sorted(p.rejected.items())), "rejected_total": sum(p.rejected.values()),
                "mode": "remote" if modes[p.index] == 1 else "grid_following", "misbehaved_tx": p.misbehaved_tx,
                "first_meas_tx_t": p.first_meas_tx_t, "first_ctrl_rx_t": p.first_ctrl_rx_t,
                "last_ctrl_rx_t": p.last_ctrl_rx_t, "ctrl_gaps_wall": p.ctrl_gaps,
                "last_ctrl_wall": p.last_ctrl_t if p.last_ctrl_t > float("-inf") else None,
                "fallbacks": int(self.model.fallbacks[p.index]), "trips": int(self.model.trips[p.index])}
        totals: dict = {key: sum(t[key] for t in turbines.values()) for key in (*COUNTERS, "rejected_total")}
        by_reason: dict[str, int] = {}
        for t in turbines.values():
            for reason, n in t["rejected"].items():
                by_reason[reason] = by_reason.get(reason, 0) + n
        totals["rejected"] = dict(sorted(by_reason.items()))
        return {"framing": self.cfg.framing, "stream": self.cfg.stream, "step_s": self.step_s, "steps": self.k,
                "t_sim": self.k * self.step_s, "turbines": turbines, "totals": totals,
                "wire": self.wire_stats.as_dict(), "internal_error": self.internal_error}
