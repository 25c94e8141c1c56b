"""The plant side of the ``time_scale: auto`` pilot (:mod:`scenarios.calibrate`): paced steps of the
scenario's plant model in the runner's process, one real MEAS per ViSC turbine from its namespace,
and the CTRL answers read back with their kernel receive stamps.

The steps run at the plant service's scheduling (:func:`plant_scheduling`): the plant service asks
for SCHED_FIFO (``realtime_priority``, :func:`sdvisc.netns.raise_priority`), so the other work on
the machine does not delay its steps; a pilot stepped at the runner's ordinary priority was
delayed by it instead and measured a plant step twice the service's (all_visc_50 at k = 8 under
load ≈ 2: the pilot's step 1.39 ms mean and 5.6 ms p99 of wall time, the plant service's 0.72 ms of
CPU per step in the run after it; benchmarks/measured/calibration-closeness-2026-12-06.json).
"""

from __future__ import annotations

import os
import time
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np

from plant.service.endpoint_tx import MeasPacker
from sdvisc import rxstamp, wire
from sdvisc.netns import raise_priority
from sdvisc.vocabulary import FILTER_R_F_PU, FILTER_X_F_PU, MEAS_FIELDS


@dataclass
class PilotSetup:
    """What one calibration talks to: the ViSC turbines' sockets, the SDC pilot, the plant model."""

    sdc_ip: str
    turbines: list[str]
    wids: dict[str, int]
    step_s: float = 0.0  # the scenario's sample period (simulated s)
    socks: dict = field(default_factory=dict)
    model: object = None
    indices: list[int] = field(default_factory=list)
    seq: int = 0  # MEAS counter, continued over the candidates (the SDC checks seq against t_sim)
    sent: dict = field(default_factory=dict)  # (wid, seq) -> (wall ns the MEAS was sent, wall ns its step began)
    step_start_ns: int = 0  # the current step's start (wall ns, the kernel stamps' clock)
    pilot_cpu_s: object = None  # () -> the pilot's CPU seconds so far (on its server, across servers)
    packer: MeasPacker = field(default_factory=lambda: MeasPacker(header=True))  # the plant service's encoder
    scheduling: str = "default"  # what plant_scheduling obtained for the steps


@contextmanager
def plant_scheduling(realtime: bool, raise_to=raise_priority):
    """The calling thread at the plant service's scheduling while the pilot steps (``realtime``: the
    plant's ``realtime_priority``; ``raise_to`` as :func:`sdvisc.netns.raise_priority`), and back to
    what it had afterwards, whatever happens. Yields what was obtained (``SCHED_FIFO:10``,
    ``nice:-10`` or ``default``)."""
    if not realtime:
        yield "default"
        return
    policy, param = os.sched_getscheduler(0), os.sched_getparam(0)
    niceness = os.getpriority(os.PRIO_PROCESS, 0)
    got = raise_to()
    try:
        yield got
    finally:
        try:
            os.sched_setscheduler(0, policy, param)
            os.setpriority(os.PRIO_PROCESS, 0, niceness)
        except OSError:
            pass


def step_once(setup: PilotSetup) -> None:
    """One plant step with the remote turbines held at their operating point, then one MEAS per
    ViSC turbine from its namespace, as the plant service sends it."""
    model = setup.model
    model.step()
    meas = model.measurements()
    idx = np.asarray(setup.indices)
    v = meas["v_d"][idx] + 1j * meas["v_q"][idx]
    i = meas["i_d"][idx] + 1j * meas["i_q"][idx]
    v_conv = v + complex(FILTER_R_F_PU, FILTER_X_F_PU) * i
    model.apply_remote(idx, v_conv.real, v_conv.imag, i.real, i.imag)
    setup.seq += 1
    t_sim = setup.seq * setup.step_s
    dst = (setup.sdc_ip, wire.PORT_SDC)
    columns = [meas[key] for key in MEAS_FIELDS]
    for j, wt in enumerate(setup.turbines):
        now_ns = time.time_ns()
        sec, nsec = divmod(now_ns, 1_000_000_000)
        data = setup.packer.pack(setup.wids[wt], setup.seq, t_sim, [float(c[setup.indices[j]]) for c in columns],
                                 sec, nsec)
        setup.sent[(setup.wids[wt], setup.seq)] = (now_ns, setup.step_start_ns)
        setup.socks[wt].sendto(data, dst)


def probe(setup: PilotSetup, period: float, steps: int, into: tuple) -> tuple[np.ndarray, np.ndarray]:
    """``steps`` paced steps of ``period`` wall seconds; the answers go into ``into`` (round trips,
    returns, answer times: :func:`drain`); returns each step's wall seconds (drain + step + sends)
    and how late each began (wall s after its schedule)."""
    plant_s, lateness = np.empty(steps), np.empty(steps)
    start = time.perf_counter()
    for n in range(steps):
        delay = start + n * period - time.perf_counter()
        if delay > 0:
            time.sleep(delay)
        t0 = time.perf_counter()
        lateness[n] = t0 - (start + n * period)
        setup.step_start_ns = time.time_ns()
        drain(setup, *into)
        step_once(setup)
        plant_s[n] = time.perf_counter() - t0
    time.sleep(max(0.2, 20 * period))
    drain(setup, *into)
    return plant_s, lateness


def drain(setup: PilotSetup, rtt: dict, back: dict, answer: dict) -> None:
    """Every CTRL waiting on the turbines' sockets: its round trip (MEAS sent → CTRL received), its
    return (the SDC's header stamp → received) and its answer time (its MEAS's step start →
    received), wall ms, per turbine."""
    for wt, sock in setup.socks.items():
        while (got := rxstamp.recv(sock)) is not None:
            data, _addr, t_rx = got
            try:
                msg = wire.decode(data, header=True)
            except wire.WireError:
                continue
            if msg.type != wire.MsgType.CTRL:
                continue
            sent = setup.sent.pop((msg["wt"], msg["meas_seq"]), None)
            if sent is None:
                continue
            t_send, t_step = sent
            rtt[wt].append((t_rx - t_send) * 1e-6)
            answer[wt].append((t_rx - t_step) * 1e-6)
            if msg.header is not None:
                back[wt].append((t_rx - (msg.header.sec * 1_000_000_000 + msg.header.nsec)) * 1e-6)
