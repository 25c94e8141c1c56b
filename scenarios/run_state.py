"""What a run reads back from its services while it plays: the SDN app's and the plant's state
files (written atomically by them in the output directory), and a turbine's installed path."""

from __future__ import annotations

import json


class RunState:
    """Mixed into :class:`scenarios.runner.Run` (needs ``out``, ``scenario`` and ``desc``)."""

    def _sdn_state_files(self) -> list[str]:
        return ["sdn_state.json"] + (["sdn2_state.json"] if self.scenario.sdn.redundancy else [])

    def _read_state(self, name: str) -> dict | None:
        try:
            return json.loads((self.out / name).read_text())
        except (OSError, json.JSONDecodeError):
            return None

    def sdn_state(self) -> dict | None:
        """The live view of the SDN app in charge (the master, with a redundant pair)."""
        states = [s for s in (self._read_state(n) for n in self._sdn_state_files()) if s]
        if not states:
            return None
        masters = [s for s in states if s.get("role") in ("master", "equal")]
        return max(masters or states, key=lambda s: (s.get("generation", 0), s.get("t_wall", 0)))

    def plant_status(self) -> dict | None:
        """The plant's live status; for a real card (which writes none for us) ``t_sim`` from the run's
        clock (issue 42: the progress bar stayed at t = 0 for a whole run)."""
        status = self._read_state("plant_status.json") or self._read_state("gtnet_card_status.json")
        peer = self.scenario.plant.peer
        if status is None and peer is not None and not peer.emulate and self.t0 is not None:
            return {"t_sim": round(max(0.0, self.clock.now() - self.t0), 6)}
        return status

    def progress_status(self) -> dict:
        """:meth:`plant_status` for the progress line: what a real card's run cannot count shown as
        ``n/a``, not 0."""
        status = self.plant_status() or {}
        peer = self.scenario.plant.peer
        if peer is not None and not peer.emulate and "meas_tx" not in status:
            status = {**status, "late_steps": "n/a", "meas_tx": "n/a", "ctrl_rx": "n/a"}
        return status

    def current_path_link(self, wt: str, hop: int) -> tuple[str, str] | None:
        """The ``hop``-th switch-to-switch link of ``wt``'s installed path (SDC side first)."""
        state = self.sdn_state() or {}
        path = state.get("tables", {}).get("paths", {}).get(wt, {}).get("path")
        if not path:
            return None
        switches = self.desc["switches"]
        inner = [(a, b) for a, b in zip(path, path[1:]) if a in switches and b in switches]
        return inner[hop % len(inner)] if inner else None
