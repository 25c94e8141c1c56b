"""What the plant service publishes while it runs, for the runner's CLI and live view.

* ``plant_status.json`` (replaced atomically every :data:`STATUS_EVERY_S` simulated seconds):
  simulated time, steps, late steps, packet totals, the streaming (ViSC) turbines, and per turbine
  its packet counters and, for the streaming ones, V (|v|, p.u.), P, Q (p.u.), f (Hz, from the
  turbine's measured speed) and the mean one-way delay of the control packets since the last
  status.
* ``plant_events.jsonl`` (one line per event as it happens; the same records go to
  ``plant_stats.json`` → ``events.jsonl`` at the end): requests and commands the plant carried out
  and what happened to each streaming turbine's control packets — ``ctrl_started`` (the first
  control packet after a stream start), ``ctrl_lost`` (none for :data:`LOSS_REPORT_S`; ``t_loss``
  is the last one) and ``ctrl_restored`` (the first one after a gap of at least
  :data:`LOSS_REPORT_S`; ``t_loss``, ``gap_ms``). Their ``t`` is the run clock's reading (s from
  t = 0), the axis of the SDN app's events.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from sdvisc.latest_writer import LatestWriter
from sdvisc.vocabulary import F_NOMINAL_HZ

STATUS_EVERY_S = 0.05  # simulated seconds between two plant_status.json
LOSS_REPORT_S = 0.020  # a silence this long is a loss of control packets (summary: MIN_INTERRUPTION_S)


class LivePublisher:
    """The plant's live status file and event stream (see the module docstring)."""

    def __init__(self, out_dir: Path | None, events: list[dict]) -> None:
        """``out_dir`` None: events are only collected (no files)."""
        self.out_dir = Path(out_dir) if out_dir is not None else None
        self.events = events  # the service's list of applied events (plant_stats.json)
        self._file = (open(self.out_dir / "plant_events.jsonl", "a", buffering=1)  # noqa: SIM115 - closed in close()
                      if self.out_dir is not None else None)
        # written off the paced loop: a busy disk must not make steps late
        self._status = LatestWriter(self.out_dir / "plant_status.json") if self.out_dir is not None else None
        self.t0 = 0.0

    def event(self, record: dict) -> None:
        self.events.append(record)
        if self._file is not None:
            self._file.write(json.dumps(record) + "\n")

    def _t(self, now: float) -> float:
        return round(now - self.t0, 6)

    # ------------------------------------------------------------------ control packets
    def on_ctrl(self, ep, now: float) -> None:
        """A control packet arrived for ``ep`` (before its ``last_ctrl_wall`` is updated)."""
        if ep.awaiting_first_ctrl:
            ep.awaiting_first_ctrl = False
            ep.ctrl_lost_reported = False
            self.event({"t": self._t(now), "type": "ctrl_started", "wt": ep.name,
                        "after_ms": round((now - ep.stream_started_wall) * 1e3, 3)})
            return
        gap = now - ep.last_ctrl_wall
        if gap >= LOSS_REPORT_S:
            self.event({"t": self._t(now), "type": "ctrl_restored", "wt": ep.name,
                        "t_loss": self._t(ep.last_ctrl_wall), "gap_ms": round(gap * 1e3, 3)})
        ep.ctrl_lost_reported = False

    def check_losses(self, endpoints, now: float) -> None:
        """Report each streaming turbine whose control packets stopped (once per loss)."""
        for ep in endpoints:
            if (ep.streaming and not ep.awaiting_first_ctrl and not ep.ctrl_lost_reported
                    and now - ep.last_ctrl_wall >= LOSS_REPORT_S):
                ep.ctrl_lost_reported = True
                self.event({"t": self._t(now), "type": "ctrl_lost", "wt": ep.name,
                            "t_loss": self._t(ep.last_ctrl_wall)})

    # ------------------------------------------------------------------ status
    def write_status(self, core, now: float, late_steps: int) -> None:
        """Replace ``plant_status.json`` (compact JSON, one write and a rename in a background thread:
        a reader never sees half a file, the paced loop never waits for the disk) with the state of
        ``core`` (a :class:`plant.service.core.PlantCore`; ``late_steps``: the paced loop's).
        Turbines that never sent or received a packet are left out (a 50-turbine farm with a few
        ViSC turbines stays small)."""
        endpoints = core.endpoints
        streaming = [ep for ep in endpoints if ep.streaming]
        turbines = {ep.name: {"streaming": False, "meas_tx": ep.counts["meas_tx"], "ctrl_rx": ep.counts["ctrl_rx"]}
                    for ep in endpoints if not ep.streaming and (ep.counts["meas_tx"] or ep.counts["ctrl_rx"])}
        if streaming:
            meas = core.model.measurements()
            index = [ep.index for ep in streaming]
            v = np.hypot(meas["v_d"][index], meas["v_q"][index]).tolist()
            p, q = meas["p"][index].tolist(), meas["q"][index].tolist()
            f = (meas["omega_meas"][index] * F_NOMINAL_HZ).tolist()
            for j, ep in enumerate(streaming):
                delay_sum_ms, delay_n = ep.live_delay
                ep.live_delay[:] = [0.0, 0]
                turbines[ep.name] = {
                    "streaming": True, "meas_tx": ep.counts["meas_tx"], "ctrl_rx": ep.counts["ctrl_rx"],
                    "v": round(v[j], 6), "p": round(p[j], 6), "q": round(q[j], 6), "f_hz": round(f[j], 5),
                    "ctrl_delay_ms": round(delay_sum_ms / delay_n, 4) if delay_n else None,
                    "t_last_ctrl": self._t(ep.last_ctrl_wall) if ep.last_ctrl_wall > float("-inf") else None}
        status = {"t_sim": core.k * core.step_s, "steps": core.k, "n_steps": core.n_steps,
                  "late_steps": late_steps, "t_wall": now,
                  "meas_tx": sum(ep.counts["meas_tx"] for ep in endpoints),
                  "ctrl_rx": sum(ep.counts["ctrl_rx"] for ep in endpoints),
                  "streaming": [ep.name for ep in streaming], "turbines": turbines}
        if self._status is not None:
            self._status.put(json.dumps(status, separators=(",", ":")).encode())

    def close(self) -> None:
        """Write the last status and close the event stream."""
        if self._status is not None:
            self._status.close()
            self._status = None
        if self._file is not None:
            self._file.close()
            self._file = None
