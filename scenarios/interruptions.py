"""What every fault did to each affected ViSC turbine's control packets, measured the same way
whatever reacted (a fast-failover group in the data plane, port status, DR, an SDC failover, or
nothing) and with no threshold below which a repair disappears.

The plant records every pause between two control packets longer than :data:`GAP_MIN_STEPS`
samples (its receive loop reads packets once per step, so a pause is measured to a step). For a
fault at ``t_f`` and a turbine it affects (``affected`` in the timeline record: the turbines whose
path crossed the failed link, or that the killed SDC or lost server served; every turbine that was receiving
control if the record does not say):

* ``interruption_ms``: the longest pause that ends after ``t_f`` and begins before the turbine's
  control came back for good — :data:`STEADY_S` without a pause: the first pause counts if it begins
  within ``STEADY_S`` of the fault, each further one if it begins within ``STEADY_S`` of the end of
  the one before (a pause 0.7 s after a hitless repair, a busy machine's, is not the fault's); at most
  ``window_s`` after the fault — or ``None`` when there was no
  pause above :data:`GAP_MIN_STEPS` samples (``above_2ts`` False: a repair faster than two samples
  — still counted, as "no interruption above 2·Ts");
* ``restored_ms``: fault → the first control packet after that pause (packets already in flight
  at the fault do not count as restoration; at most ``2·Ts`` when there was no pause);
* ``recovered``: False when control stopped for good within the window (the run's end excepted).

And what the network itself needed, free of the endpoints' own delays: each datagram carries its
send time (header) and a sequence number, so where MEAS were lost on the way to the SDC (its
``meas_resumed``) or CTRL on the way back (the plant's ``ctrl_resumed``), the first datagram that
got through again was sent when the path could deliver once more:

* ``meas_path_ms`` / ``ctrl_path_ms``: fault → the send time of the first MEAS (CTRL) that arrived
  after those the fault lost, within the same chain of losses as above (``STEADY_S``); an upper
  bound of the path's repair, to one sample. ``None``: that direction lost nothing (a CTRL is only
  sent for a MEAS that arrived, so a CTRL loss is counted only while MEAS got through);
* ``path_restored_ms``: the larger of the two — when both directions delivered again. For a
  fast-failover repair this is Open vSwitch's own repair on the run's topology under the run's load
  (no application acts); ``interruption_ms`` minus it is what the plant's and the SDC's pacing and
  the round trip added.
"""

from __future__ import annotations

import numpy as np

from plant.service.core import (
    CTRL_GAP_STEPS as GAP_MIN_STEPS,  # the plant records pauses longer than this (steps)
)

FAULT_TYPES = ("link_down", "kill", "server_down")
RESTORE_TYPES = ("link_up", "restore_links")
"""Timeline events that end a fault: measured as well (``restore_interruptions``: a link's return can
interrupt control too, e.g. while the L2 switch relearns), never counted as the fault's."""
WINDOW_S = 1.0
STEADY_S = 0.1  # control without a pause this long (2.5 DR holds) is back for good


def interruptions(faults: list[dict], plant_turbines: dict, t0: float | None, step_s: float, duration_s: float,
                  window_s: float = WINDOW_S, sdc_turbines: dict | None = None,
                  boundaries: list[float] = ()) -> list[dict]:
    """One record per (fault, affected turbine); see the module docstring. ``plant_turbines``: the
    plant's per-turbine stats (``ctrl_gaps_wall`` as [start, end] wall… pairs on the run's clock,
    ``first_ctrl_rx_t``/``last_ctrl_wall``, ``ctrl_resumed``); ``t0``: the run clock's reading at
    t = 0; ``sdc_turbines``: per turbine, every SDC's ``meas_resumed`` lists joined; ``boundaries``: times of
    other events that end a fault's window as the next fault does (a failed link restored: what its
    return does is the restore's, :data:`RESTORE_TYPES`)."""
    if t0 is None:
        return []
    out = []
    bound_ms = round(2 * step_s * 1e3, 3)
    times = sorted([f.get("t_effective", f["t"]) for f in faults] + list(boundaries))
    for fault in faults:
        t_f = fault.get("t_effective", fault["t"])
        later = [t for t in times if t > t_f]
        # a pause whose last packet came just before the next fault (within the time a pause needs to
        # be one) is the next fault's
        end = min([t_f + window_s, duration_s] + [t - GAP_MIN_STEPS * step_s for t in later[:1]])
        for wt in _affected(fault, plant_turbines, t0, t_f):
            stats = plant_turbines[wt]
            gaps = [(a - t0, b - t0) for a, b in stats.get("ctrl_gaps_wall", [])]
            last = stats.get("last_ctrl_wall")
            last_t = last - t0 if last is not None else None
            # the run's last STEADY_S are its end, not a fault's (a loaded machine's last pause came
            # 3.8 ms before the end of a failover run and was counted as control stopped for good)
            stopped = last_t is not None and last_t < end and last_t < duration_s - STEADY_S
            around = _of_the_fault(sorted((a, b) for a, b in gaps if b > t_f and a < end), t_f)
            longest = max(around, key=lambda g: g[1] - g[0], default=None)
            meas_ms = path_repair_ms((sdc_turbines or {}).get(wt, []), t0, t_f, end, step_s)
            ctrl_ms = path_repair_ms(stats.get("ctrl_resumed", []), t0, t_f, end, step_s)
            out.append({
                "wt": wt, "fault": fault.get("type"), "t_fault": round(t_f, 6),
                "link": [fault["a"], fault["b"]] if "a" in fault else None,
                "interruption_ms": round((longest[1] - longest[0]) * 1e3, 3) if longest else None,
                "above_2ts": longest is not None or stopped,
                "restored_ms": None if stopped else (round((longest[1] - t_f) * 1e3, 3) if longest else bound_ms),
                "recovered": not stopped,
                "t_loss": round(longest[0], 6) if longest else (round(last_t, 6) if stopped else None),
                "meas_path_ms": meas_ms, "ctrl_path_ms": ctrl_ms,
                "path_restored_ms": max((v for v in (meas_ms, ctrl_ms) if v is not None), default=None),
            })
    return out


def path_repair_ms(resumed: list, t0: float, t_f: float, end: float, step_s: float) -> float | None:
    """Fault at ``t_f`` → the send time of the first datagram through after the losses it caused
    (``resumed``: [send time on the run clock, datagrams lost before it]); the losses chained as in
    :func:`_of_the_fault`; None if the fault lost nothing in this direction."""
    steady_from, last = t_f, None
    for sent, lost in sorted((sent - t0, lost) for sent, lost in resumed):
        if sent <= t_f or sent >= end:
            continue
        if sent - lost * step_s > steady_from + STEADY_S:  # this loss began after control was back for good
            break
        last = steady_from = sent
    return round((last - t_f) * 1e3, 3) if last is not None else None


def _of_the_fault(pauses: list[tuple[float, float]], t_f: float) -> list[tuple[float, float]]:
    """The pauses (sorted by start) before control was back for good after the fault at ``t_f``."""
    out: list[tuple[float, float]] = []
    steady_from = t_f
    for a, b in pauses:
        if a > steady_from + STEADY_S:
            break
        out.append((a, b))
        steady_from = max(steady_from, b)
    return out


def _affected(fault: dict, plant_turbines: dict, t0: float, t_f: float) -> list[str]:
    if "affected" in fault:
        return [wt for wt in fault["affected"] if wt in plant_turbines]
    return sorted(wt for wt, st in plant_turbines.items()  # every turbine receiving control at the fault
                  if st.get("last_ctrl_wall") is not None and st.get("first_ctrl_rx_t") is not None
                  and st["first_ctrl_rx_t"] <= t_f and st["last_ctrl_wall"] - t0 >= t_f - 0.05)


def aggregate(records: list[dict], step_s: float) -> dict:
    """Percentiles over *all* records (one per fault and affected turbine: ``faults`` counts those
    pairs; a record without a pause above two samples counts as 2·Ts, an upper bound), the count
    with no interruption above 2·Ts, and the unrecovered count."""
    values = [r["interruption_ms"] if r["interruption_ms"] is not None else 2 * step_s * 1e3
              for r in records if r["recovered"]]
    paths = [r.get("path_restored_ms") or step_s * 1e3 for r in records if r["recovered"] and "path_restored_ms" in r]
    out = {"faults": len(records), "no_interruption_above_2ts": sum(not r["above_2ts"] for r in records),
           "unrecovered": sum(not r["recovered"] for r in records)}
    if values:
        a = np.asarray(values)
        out.update(p50=round(float(np.percentile(a, 50)), 3), p95=round(float(np.percentile(a, 95)), 3),
                   max=round(float(a.max()), 3))
    if paths:  # what the network needed (nothing lost: one sample, an upper bound)
        b = np.asarray(paths)
        out["path_restored_ms"] = {"p50": round(float(np.percentile(b, 50)), 3),
                                   "p95": round(float(np.percentile(b, 95)), 3), "max": round(float(b.max()), 3)}
    return out
