"""What a run sees of a real GTNET-SKT card (``plant.peer`` with ``emulate: false``; issue 42 item 8).

A card the run did not start writes no statistics for us. What the testbed does see is the traffic on
the interface cabled to it: the run captures it with ``tcpdump`` (:func:`start`: the process
``peer.tcpdump``, ``udp and host <card IP>``, into ``peer_tap.pcap``) and, after the run,
:func:`turbine_stats` counts per turbine, in the plant statistics' shape (so the summary's
``recoveries`` and ``interruptions`` are measured as for the testbed's own plant):

* ``meas_tx``: MEAS the card put on its link; ``ctrl_rx``: CTRL delivered to its link; ``ak_tx`` and
  ``ak_ones``: its AKs (all, and those with ``ak`` = 1);
* ``ctrl_gaps_wall``: every pause between two CTRL longer than the plant's threshold
  (:data:`plant.service.core.CTRL_GAP_STEPS` samples), ``last_ctrl_wall``, ``first_ctrl_rx_t`` and
  ``last_ctrl_rx_t``: from the capture's timestamps (the kernel's receive time on the interface, µs)
  on the run's clock. A pause is measured at the card's cable, to the microsecond, not to a plant
  step (the card's own reading of a CTRL comes after its next step begins, up to one Ts later);
* from the AK stream (what the card itself reports every ``ak_period_s``, 10 ms): ``card_ctrl_rx``
  (its own CTRL count in its last AK), ``ak_zero`` (intervals from the first AK with ``ak`` = 0 to
  the next with ``ak`` = 1, seconds from t = 0: to one AK period) and ``ctrl_age_max_ms``.

What stays unknown is marked ``None`` (the summary and the CLI say "n/a (real card)"): the card's
steps and late steps, its rejections and stale CTRL.
"""

from __future__ import annotations

import re
import struct
import sys
from collections.abc import Iterable, Iterator
from pathlib import Path

from plant.service.core import CTRL_GAP_STEPS
from sdvisc import wire

PCAP = "peer_tap.pcap"
PROCESS = "peer.tcpdump"  # scenarios.processes stops ``*.tcpdump`` with SIGINT, after the services
ETH_IPV4, ETH_VLAN = 0x0800, 0x8100
IP_UDP = 17


def start(run, interface: str, card_ip: str) -> None:
    """Capture the card's UDP traffic on ``interface`` (root namespace) for the whole run."""
    run.processes.start(PROCESS, ["tcpdump", "-i", interface, "-B", "16384", "--immediate-mode", "-U", "-Z", "root",
                                  "-w", str(run.out / PCAP), f"udp and host {card_ip}"])


def frames(path: Path) -> Iterator[tuple[float, bytes]]:
    """(wall time, frame) of every frame in a pcap file (scapy's raw reader: no dissection)."""
    from scapy.utils import RawPcapReader  # noqa: PLC0415 - scapy is slow to import, needed only here

    with RawPcapReader(str(path)) as reader:
        for data, meta in reader:
            yield meta.sec + meta.usec * 1e-6, data


def udp_datagrams(captured: Iterable[tuple[float, bytes]]) -> Iterator[tuple[float, str, str, int, int, bytes]]:
    """(wall time, source IP, destination IP, source port, destination port, payload) of every IPv4
    UDP datagram among Ethernet frames (an 802.1Q tag skipped; fragments and the rest left out)."""
    for t, frame in captured:
        off = 12
        eth_type = struct.unpack_from(">H", frame, off)[0] if len(frame) >= 14 else 0
        if eth_type == ETH_VLAN and len(frame) >= 18:
            off += 4
            eth_type = struct.unpack_from(">H", frame, off)[0]
        ip = off + 2
        if eth_type != ETH_IPV4 or len(frame) < ip + 20 or frame[ip + 9] != IP_UDP:
            continue
        udp = ip + (frame[ip] & 0x0F) * 4
        if len(frame) < udp + 8:
            continue
        sport, dport, length = struct.unpack_from(">HHH", frame, udp)
        src, dst = ".".join(map(str, frame[ip + 12:ip + 16])), ".".join(map(str, frame[ip + 16:ip + 20]))
        yield t, src, dst, sport, dport, bytes(frame[udp + 8:udp + length])


def turbine_stats(datagrams: Iterable[tuple[float, str, str, int, int, bytes]], *, card_ip: str, header: bool,
                  turbines: dict[str, int], from_wall, t0: float, step_s: float) -> dict:
    """Per turbine the counts and pauses of the module docstring, and what the capture held
    (``datagrams``: :func:`udp_datagrams`; ``from_wall``: the run clock's reading of a wall time;
    ``t0``: its reading at t = 0). Pure: no file, no clock of its own."""
    rows = {name: _Row() for name in turbines}
    seen = {"datagrams": 0, "undecoded": 0, "other": 0}
    for wall, src, dst, _sport, _dport, payload in datagrams:
        seen["datagrams"] += 1
        try:
            msg = wire.decode(payload, header=header)
        except wire.WireError:
            seen["undecoded"] += 1
            continue
        name = _turbine(msg)
        row = rows.get(name) if name else None
        if row is None:
            seen["other"] += 1
            continue
        t = from_wall(wall)
        if msg.type == wire.MsgType.MEAS and src == card_ip:
            row.meas_tx += 1
            row.first_meas = t if row.first_meas is None else row.first_meas
        elif msg.type == wire.MsgType.CTRL and dst == card_ip:
            if row.last_ctrl is not None and t - row.last_ctrl > CTRL_GAP_STEPS * step_s:
                row.gaps.append([row.last_ctrl, t])
            row.ctrl_rx += 1
            row.first_ctrl = t if row.first_ctrl is None else row.first_ctrl
            row.last_ctrl = t
        elif msg.type == wire.MsgType.AK and src == card_ip:
            row.on_ak(t - t0, int(msg["ak"]), int(msg["ctrl_rx"]), float(msg["ctrl_age_ms"]))
        else:
            seen["other"] += 1
    return {"captured": seen, "turbines": {name: row.as_stats(t0) for name, row in rows.items()}}


def _turbine(msg: wire.Message) -> str | None:
    try:
        return wire.turbine_name(int(msg["wt"]))
    except (KeyError, ValueError):
        return None


class _Row:
    """One turbine's counts while the capture is read."""

    def __init__(self) -> None:
        self.meas_tx = self.ctrl_rx = self.ak_tx = self.ak_ones = 0
        self.first_meas = self.first_ctrl = self.last_ctrl = None
        self.gaps: list[list[float]] = []
        self.card_ctrl_rx: int | None = None
        self.ak_zero: list[list[float | None]] = []
        self.age_max_ms = 0.0

    def on_ak(self, t: float, ak: int, ctrl_rx: int, age_ms: float) -> None:
        self.ak_tx += 1
        self.ak_ones += ak
        self.card_ctrl_rx = ctrl_rx
        if self.first_ctrl is not None:  # before the first CTRL the age says nothing of a loss
            self.age_max_ms = max(self.age_max_ms, age_ms)
        if not ak and self.first_ctrl is not None and (not self.ak_zero or self.ak_zero[-1][1] is not None):
            self.ak_zero.append([round(t, 6), None])
        elif ak and self.ak_zero and self.ak_zero[-1][1] is None:
            self.ak_zero[-1][1] = round(t, 6)

    def as_stats(self, t0: float) -> dict:
        def since_t0(t):
            return round(t - t0, 6) if t is not None else None
        return {"meas_tx": self.meas_tx, "ctrl_rx": self.ctrl_rx, "ak_tx": self.ak_tx, "ak_ones": self.ak_ones,
                "ctrl_stale": None, "rx_rejected": None,
                "first_meas_tx_t": since_t0(self.first_meas), "first_ctrl_rx_t": since_t0(self.first_ctrl),
                "last_ctrl_rx_t": since_t0(self.last_ctrl), "last_ctrl_wall": self.last_ctrl,
                "ctrl_gaps_wall": self.gaps, "ctrl_resumed": [],
                "card_ctrl_rx": self.card_ctrl_rx, "ak_zero": self.ak_zero,
                "ctrl_age_max_ms": round(self.age_max_ms, 3)}


KERNEL_DROPS = re.compile(r"(\d+) packets? dropped by kernel")


def read(run) -> dict | None:
    """The capture of a real card's run as :func:`turbine_stats` (with ``dropped_by_kernel`` from
    tcpdump's log), or None without a capture (an emulated card, or tcpdump did not run)."""
    peer = run.scenario.plant.peer
    path = run.out / PCAP
    if peer is None or peer.emulate or run.t0 is None or not path.exists() or path.stat().st_size == 0:
        return None
    from scapy.error import Scapy_Exception  # noqa: PLC0415 - as frames()

    try:
        stats = turbine_stats(udp_datagrams(frames(path)), card_ip=peer.ip, header=peer.framing == "villas",
                              turbines=dict(peer.turbines), from_wall=run.clock.from_wall, t0=run.t0,
                              step_s=run.scenario.step_s)
    except (Scapy_Exception, OSError, EOFError) as exc:  # e.g. tcpdump killed before its file header
        print(f"sdvisc: the capture of the card's traffic ({path}) is unreadable: {exc}", file=sys.stderr)
        return None
    try:
        drops = KERNEL_DROPS.search((run.out / f"{PROCESS}.log").read_text())
    except OSError:
        drops = None
    stats["captured"]["dropped_by_kernel"] = int(drops.group(1)) if drops else None
    stats["interface"] = peer.interface
    return stats
