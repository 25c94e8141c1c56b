"""Controller redundancy (beyond the paper): two app instances, OpenFlow master/slave roles.

Both instances connect to every switch and receive the same packet-ins and port-status messages
(the slave asks for them with an OpenFlow async configuration), so both run the same pure logic on
the same inputs; only the master's messages are sent. The master sends a peer heartbeat to the
slave every ``heartbeat_s``; when none has arrived for ``takeover_s`` the slave asks every switch
for the master role with a higher generation id (the switches then demote the old master) and its
decisions take effect. Pure: the clock is passed in.
"""

from __future__ import annotations

from dataclasses import dataclass

ROLES = ("master", "slave", "equal")


@dataclass
class RoleState:
    """One instance's role and its view of the peer."""

    role: str = "equal"
    generation: int = 1
    heartbeat_s: float = 0.010
    takeover_s: float = 0.050
    startup_grace_s: float = 2.0
    t_start: float = 0.0
    t_peer: float | None = None
    takeovers: int = 0

    def __post_init__(self):
        if self.role not in ROLES:
            raise ValueError(f"role must be one of {ROLES}, got {self.role!r}")

    @property
    def sends(self) -> bool:
        """Whether this instance's decisions are sent to the switches."""
        return self.role != "slave"

    def on_peer_heartbeat(self, generation: int, now: float) -> None:
        self.t_peer = now
        self.generation = max(self.generation, generation)

    def should_take_over(self, now: float) -> bool:
        """A slave takes over once the master has been silent for ``takeover_s`` (or never spoke
        within the start-up grace)."""
        if self.role != "slave":
            return False
        last = self.t_peer if self.t_peer is not None else self.t_start + self.startup_grace_s
        return now - last > self.takeover_s

    def take_over(self) -> int:
        """Become master; returns the generation id to claim the role with."""
        self.role = "master"
        self.generation += 1
        self.takeovers += 1
        return self.generation
