"""The scenario keys for real devices in the loop (issue 29; docs/real-devices.md): an external
GTNET-SKT peer in place of the plant (``plant.peer`` with ``plant.model: external``) and OpenFlow
switches of the topology that Mininet does not build (``topology.external_switches``).

A lab's device is reached through a host interface attached to a Mininet switch (Mininet's ``Intf``
on a named interface: a physical NIC cabled to the device). With ``emulate: true`` (the default, and
what the tests use) the run makes the device's stand-in on this machine: a veth pair whose far end
is the card emulator's namespace (:mod:`plant.card`) or a port of a plain Open vSwitch bridge
created with ``ovs-vsctl`` (its own datapath id, no Mininet object), and removes it at the end.
"""

from __future__ import annotations

import ipaddress
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from plant.card.faults import Misbehaviour
from sdvisc.config import TurbineName

MAC_PATTERN = r"^[0-9a-f]{2}(:[0-9a-f]{2}){5}$"
IFNAME_PATTERN = r"^[A-Za-z0-9_.-]{1,15}$"
"""A Linux interface name (at most 15 characters)."""
IfName = Annotated[str, Field(pattern=IFNAME_PATTERN)]
UdpPort = Annotated[int, Field(ge=1024, le=65535)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class PeerSpec(_Strict):
    """``plant.peer``: the external GTNET-SKT peer (an RTDS rack's card) that sends the turbines' MEAS
    and AKs and receives their CTRL and stream commands, one UDP port per turbine on one IP."""

    switch: str = Field(description="the Mininet switch the peer hangs on (its host interface is attached there)")
    interface: IfName | None = Field(None, description=(
        "the host interface cabled to the peer (a NIC); null with emulate: a veth made by the run"))
    ip: str = Field(description="the card's IPv4 address (in the farm's 10.0.0.0/16)")
    mac: str = Field(pattern=MAC_PATTERN, description="the card's MAC address (lower-case hex)")
    framing: Literal["native", "villas"] = Field("native", description=(
        "native: the card's own framing (no header, exactly the configured words); villas: VILLASnode's "
        "fake header (3 words) before them"))
    turbines: dict[TurbineName, UdpPort] = Field(min_length=1, description=(
        "turbine -> the card's UDP port for it (MEAS and AKs sent from it, CTRL and commands received on it)"))
    stream: Literal["on_request", "always"] = Field("on_request", description=(
        "emulate only: on_request = MEAS after the SDN app's STREAM_START (as the testbed's plant); always = "
        "from the start to sdc1 (a card whose draft enables it permanently: the switches drop what no path carries)"))
    emulate: bool = Field(True, description=(
        "run the project's card emulator (python -m plant.card.emulator) in a namespace of its own behind a veth"))
    misbehave: list[Misbehaviour] = Field(default_factory=list, description=(
        "emulate only: bursts of bad datagrams the card sends on purpose (plant.card.faults: wrong word "
        "count, unknown turbine, flood) - a faulty device, to check what the testbed rejects and counts"))

    @field_validator("ip")
    @classmethod
    def _farm_address(cls, value: str) -> str:
        if ipaddress.ip_address(value) not in ipaddress.ip_network("10.0.0.0/16"):
            raise ValueError("the peer's address must lie in the farm's 10.0.0.0/16")
        return value

    @model_validator(mode="after")
    def _reachable(self):
        if not self.emulate and self.interface is None:
            raise ValueError("a real peer (emulate: false) needs interface: the NIC cabled to it")
        if self.misbehave and not self.emulate:
            raise ValueError("misbehave asks the emulated card for bad datagrams: only with emulate: true")
        if unknown := sorted({m.turbine for m in self.misbehave} - set(self.turbines)):
            raise ValueError(f"misbehave names turbines the card does not serve: {', '.join(unknown)}")
        ports = list(self.turbines.values())
        if len(set(ports)) != len(ports):
            raise ValueError("each turbine needs a port of its own on the card")
        return self


class ExternalSwitchSpec(_Strict):
    """``topology.external_switches.<name>``: an OpenFlow 1.3 switch of the topology that Mininet does
    not build. Its datapath id and port numbers are the topology's (what the SDN app is told); every
    link to a Mininet switch goes through a host interface on that switch's side."""

    emulate: bool = Field(True, description=(
        "make it here: a plain Open vSwitch bridge (ovs-vsctl, own datapath id, OpenFlow 1.3, fail-mode secure, "
        "the run's SDN app as controller) joined by veths"))
    interfaces: dict[str, IfName] = Field(default_factory=dict, description=(
        "neighbour Mininet switch -> the host interface on its side cabled to this switch (needed without emulate)"))



def external_problems(desc: dict, switches: dict[str, ExternalSwitchSpec], peer: PeerSpec | None) -> list[tuple]:
    """(key path, message) for every external switch or peer that does not fit the topology ``desc``
    (:func:`topologies.base.describe`)."""
    problems = []
    known = desc["switches"]
    for name, spec in switches.items():
        loc = ("topology", "external_switches", name)
        if name not in known:
            problems.append((loc, f"no switch {name!r} in the topology (switches: {', '.join(sorted(known))})"))
            continue
        if not known[name]["openflow"]:
            problems.append((loc, f"{name} is not an OpenFlow switch: only those can be external (the SDN app controls them)"))
        on_it = sorted(h for h, info in desc["hosts"].items() if info["switch"] == name
                       and not (peer is not None and h in peer.turbines))
        if on_it:
            problems.append((loc, f"hosts hang on {name} ({', '.join(on_it)}): an external switch carries only "
                                  f"switch-to-switch links and the peer"))
        neighbours = {lk["b"] if lk["a"] == name else lk["a"] for lk in desc["links"] if name in (lk["a"], lk["b"])}
        problems += [(loc + ("interfaces", n), f"{n} is not a neighbour of {name} (neighbours: {', '.join(sorted(neighbours))})")
                     for n in spec.interfaces if n not in neighbours]
        if not spec.emulate:
            problems += [(loc + ("interfaces",), f"a real switch (emulate: false) needs the interface toward {n}")
                         for n in sorted(neighbours - set(spec.interfaces) - set(switches))]
    if peer is not None:
        loc = ("plant", "peer", "switch")
        if peer.switch not in known:
            problems.append((loc, f"no switch {peer.switch!r} in the topology"))
        elif peer.switch in switches:
            problems.append((loc, f"{peer.switch} is external: the peer hangs on a switch of the run"))
        taken = {info["ip"]: h for h, info in desc["hosts"].items() if h not in peer.turbines}
        if peer.ip in taken:
            problems.append((("plant", "peer", "ip"), f"{peer.ip} is {taken[peer.ip]}'s address"))
    return problems
