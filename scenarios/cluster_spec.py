"""The ``cluster:`` scenario key (issue 30; docs/cluster.md "Running a scenario across servers"):
the run's network spread over servers with Mininet's cluster mode (topologies/cluster.py).

What runs where: the **head** (this machine: the runner, the SDN app, the plant, the OWFCC) keeps
the turbine hosts, the plant-side layer-2 switches and the controller's intake host, because the
plant is one process that opens every turbine's socket in the turbine host's own network namespace
(one model, one step; docs/cluster.md says why a relay per server was not chosen). The OpenFlow
switches and the SDC hosts go to the servers: ``placement: by_role`` puts the OpenFlow switches on
the servers in turn (in datapath-id order) and every SDC with its switch; ``by_cluster`` puts an
OpenFlow switch that turbines of farm cluster ``c`` hang on on server ``(c - 1) mod N`` and the
others (substation, core) as ``by_role``; a mapping ``{node: server}`` (``head`` for this machine)
overrides either per node. A link between two places is a VXLAN tunnel.

``servers`` names real machines (reached with ssh as root with a key, or a user with password-less
sudo); ``emulate: N`` makes ``N`` stand-in servers on this machine for the run
(:func:`host_tools.servers.make_servers`: namespaces with their own sshd and Open vSwitch) named
``srv1`` … ``srvN``, and removes them at the end. Real servers need the project installed at the
same path and the run's output directory on a shared file system (the services write their
statistics there), as this machine's stand-ins have.
"""

from __future__ import annotations

import ipaddress
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

HEAD = "head"
"""The name of this machine in a placement (Mininet's ``localhost``)."""
SERVER_NAME_PATTERN = r"^[a-z][a-z0-9_-]{0,14}$"
ServerName = Annotated[str, Field(pattern=SERVER_NAME_PATTERN)]
HEAD_ROLES = ("turbine", "impairment", "intake")
"""Host roles that stay on the head (the plant's sockets, the impairment elements, the app's intake)."""


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class ServerSpec(_Strict):
    """``cluster.servers.<name>``: one real machine."""

    address: str = Field(description="the server's IPv4 address on the LAN that joins the servers and the head")
    user: str = Field("root", description="ssh user: root, or one with password-less sudo")
    key: str | None = Field(None, description="the private key that opens it (default: ssh's own)")

    @field_validator("address")
    @classmethod
    def _ipv4(cls, value: str) -> str:
        try:
            ipaddress.IPv4Address(value)
        except ValueError:
            raise ValueError(f"expected an IPv4 address, not {value!r}") from None
        return value


class ClusterSpec(_Strict):
    """``cluster``: the run across servers (see the module docstring)."""

    servers: dict[ServerName, ServerSpec] = Field(default_factory=dict, description="real machines by name")
    emulate: int = Field(0, ge=0, le=8, description=(
        "make this many stand-in servers srv1..srvN on this machine for the run (tests; docs/cluster.md)"))
    lan: str = Field("10.250.0.0/24", description="emulate: the stand-in servers' LAN (head .1, server i .1i)")
    placement: Literal["by_role", "by_cluster"] | dict[str, ServerName] = Field("by_role", description=(
        "by_role: OpenFlow switches on the servers in turn, each SDC with its switch, the rest on the head; "
        "by_cluster: a switch with turbines of farm cluster c on server (c - 1) mod N, the others by role; or "
        "node -> server (head: this machine), the others by role"))
    tunnel: Literal["vxlan"] = Field("vxlan", description=(
        "links between places: VXLAN (UDP 4789; GRE is not in this project's kernels)"))

    @field_validator("lan")
    @classmethod
    def _network(cls, value: str) -> str:
        if ipaddress.IPv4Network(value).num_addresses < 64:
            raise ValueError("the LAN needs at least 64 addresses")
        return value

    @model_validator(mode="after")
    def _one_kind(self):
        if bool(self.servers) == bool(self.emulate):
            raise ValueError("give servers (real machines) or emulate: N (stand-ins on this machine), one of them")
        if HEAD in self.servers:
            raise ValueError(f"{HEAD!r} is this machine's name in a placement: call the server something else")
        return self

    def server_names(self) -> list[str]:
        return list(self.servers) if self.servers else [f"srv{i}" for i in range(1, self.emulate + 1)]


def place(desc: dict, topo_roles: dict[str, str], spec: ClusterSpec) -> dict[str, str]:
    """node -> place (a server's name or :data:`HEAD`) for every host and switch of a topology:
    ``desc`` is :func:`topologies.base.describe`'s, ``topo_roles`` node -> role for the nodes it
    leaves out (the intake host and bridge, impairment elements)."""
    servers = spec.server_names()
    explicit = spec.placement if isinstance(spec.placement, dict) else {}
    out: dict[str, str] = {}
    if spec.placement == "by_cluster":
        for info in desc["hosts"].values():
            if info["role"] == "turbine" and desc["switches"].get(info["switch"], {}).get("openflow"):
                cluster_server = servers[(info["cluster"] - 1) % len(servers)]
                out.setdefault(info["switch"], cluster_server)  # (its lowest cluster: hosts come in order)
    openflow = sorted((n for n, s in desc["switches"].items() if s["openflow"] and n not in out),
                      key=lambda n: desc["switches"][n]["dpid"])
    for i, name in enumerate(openflow):
        out[name] = servers[i % len(servers)]
    out.update({n: w for n, w in explicit.items() if n in desc["switches"]})
    for name, info in desc["switches"].items():
        if not info["openflow"]:
            out[name] = HEAD
    for name, info in desc["hosts"].items():
        if name in explicit:
            out[name] = explicit[name]
        elif info["role"] == "service" and name.startswith("sdc"):
            out[name] = out.get(info["switch"], HEAD)
        else:
            out[name] = HEAD
    for name, role in topo_roles.items():
        out.setdefault(name, HEAD if role in HEAD_ROLES else servers[0])
    return out


def cluster_problems(desc: dict, spec: ClusterSpec, events: list[tuple[int, object]]) -> list[tuple]:
    """(key path, message) for every placement or server event that does not fit the topology."""
    places = {HEAD, *spec.server_names()}
    problems = []
    if isinstance(spec.placement, dict):
        for node, where in spec.placement.items():
            loc = ("cluster", "placement", node)
            if where not in places:
                problems.append((loc, f"no server {where!r} (servers: {', '.join(spec.server_names())}; or {HEAD})"))
            if node in desc["hosts"]:
                role = desc["hosts"][node]["role"]
                if role in HEAD_ROLES and where != HEAD:
                    problems.append((loc, f"{node} is a {role} host: it stays on the head with the plant, whose one "
                                          f"process opens every turbine's socket in the turbine's namespace"))
            elif node in desc["switches"]:
                if not desc["switches"][node]["openflow"] and where != HEAD:
                    problems.append((loc, f"{node} is the plant side's layer-2 switch: it stays on the head with "
                                          f"the turbines"))
            else:
                problems.append((loc, f"no host or switch {node!r} in the topology"))
    for i, event in events:
        if event.do == "server_down":
            if event.server not in spec.server_names():
                problems.append((("timeline", i, "server"), f"no server {event.server!r} (servers: "
                                                             f"{', '.join(spec.server_names())})"))
            elif not spec.emulate:
                problems.append((("timeline", i, "server"), "server_down kills a stand-in server's daemons: "
                                                             "only with emulate (a real machine is not switched off)"))
    return problems
