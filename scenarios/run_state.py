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
        return self._read_state("plant_status.json") or self._read_state("gtnet_card_status.json")

    def current_path_link(self, wt: str, hop: int) -> tuple[str, str] | None:
        """The ``hop``-th switch-to-switch link of ``wt``'s installed path (SDC side first)."""
        state = self.sdn_state() or {}
        path = state.get("tables", {}).get("paths", {}).get(wt, {}).get("path")
        if not path:
            return None
        switches = self.desc["switches"]
        inner = [(a, b) for a, b in zip(path, path[1:]) if a in switches and b in switches]
        return inner[hop % len(inner)] if inner else None
