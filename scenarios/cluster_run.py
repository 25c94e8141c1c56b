"""A run across servers (``cluster:``; scenarios/cluster_spec.py, docs/cluster.md): the servers
(stand-ins made for the run, or real machines), the network built on them with
:class:`topologies.cluster.ClusterNet`, Open vSwitch commands sent to the server that holds a switch,
a server's loss, the servers' CPU, and what ``summary.json`` says about it (``cluster``).
"""

from __future__ import annotations

import shlex
import subprocess
import time
from functools import partial

from host_tools import servers as stand_ins
from host_tools.servers import Server
from scenarios.cluster_spec import HEAD, ClusterSpec, place
from scenarios.netprep import local_vsctl
from scenarios.remote_process import as_root
from sdvisc.netns import stat_cpu_seconds
from topologies.cluster import HEAD as MININET_HEAD
from topologies.cluster import ClusterNet, RemoteVXLANLink, head_address_towards
from topologies.placers import DictPlacer

OVS_PIDFILE = "/run/openvswitch/ovs-vswitchd.pid"


def _on(server: Server, tool: str, args: list[str], stdin: str | None = None) -> subprocess.CompletedProcess:
    """``tool ARGS`` on ``server`` over ssh (as root: ``sudo -n`` for another user)."""
    return subprocess.run([*server.ssh, as_root(server.user, shlex.join([tool, *args]))], input=stdin,
                          capture_output=True, text=True, timeout=60)


class ClusterRun:
    """The servers of one run and what it built on them."""

    def __init__(self, spec: ClusterSpec) -> None:
        self.spec = spec
        self.servers: dict[str, Server] = {}  # the scenario's server name -> Server
        self.placement: dict[str, str] = {}  # node -> the scenario's place name (a server or "head")
        self.lost: dict[str, float] = {}  # server -> scenario time it was lost
        self.net: ClusterNet | None = None
        self.made = False
        self._tunnels: list[dict] | None = None

    # ------------------------------------------------------------------ set-up
    def start_servers(self) -> None:
        """Make the stand-in servers (``emulate``) or describe the real ones."""
        names = self.spec.server_names()
        if self.spec.emulate:
            self.made = True
            made = stand_ins.make_servers(self.spec.emulate, lan=self.spec.lan)
            self.servers = dict(zip(names, made))
            return
        for i, (name, real) in enumerate(self.spec.servers.items(), start=1):
            self.servers[name] = Server(name=name, index=i, ip=real.address, key=real.key, user=real.user,
                                        head_ip=head_address_towards(real.address))

    @property
    def head_ip(self) -> str:
        """The head's address on the servers' LAN (where the SDN app listens)."""
        return next(iter(self.servers.values())).head_ip

    def mininet_place(self, where: str) -> str:
        return MININET_HEAD if where == HEAD else self.servers[where].name

    def build_net(self, topo, desc: dict, **params) -> ClusterNet:
        """The topology on the servers (not started): placed by :func:`scenarios.cluster_spec.place`."""
        roles = {n: topo.nodeInfo(n).get("role", "") for n in topo.nodes() if n not in desc["hosts"]
                 and n not in desc["switches"]}
        self.placement = place(desc, roles, self.spec)
        explicit = {node: self.mininet_place(where) for node, where in self.placement.items()}
        self.net = ClusterNet(list(self.servers.values()), topo=topo, head=True, controller_ip=self.head_ip,
                              placement=partial(DictPlacer, placement=explicit), **params)
        return self.net

    # ------------------------------------------------------------------ Open vSwitch where a switch is
    def server_of(self, node: str) -> Server | None:
        where = self.placement.get(node, HEAD)
        return None if where == HEAD else self.servers[where]

    def vsctl_for(self, server: Server | None):
        """An ``ovs-vsctl`` caller (args -> stdout) on ``server`` (None: this machine)."""
        if server is None:
            return local_vsctl

        def vsctl(args: list[str]) -> str:
            res = _on(server, "ovs-vsctl", ["--timeout=30", *args])
            if res.returncode != 0:
                raise RuntimeError(f"{server.name}: ovs-vsctl {' '.join(args)}: {res.stderr.strip()}")
            return res.stdout
        return vsctl

    def switch_groups(self, switches) -> list[tuple[object, list]]:
        """(``vsctl`` caller, switches) per place that holds some of ``switches``."""
        groups: dict[str, list] = {}
        for sw in switches:
            groups.setdefault(self.placement.get(sw.name, HEAD), []).append(sw)
        return [(self.vsctl_for(None if where == HEAD else self.servers[where]), group)
                for where, group in groups.items() if where not in self.lost]

    def ovs_tool(self, tool: str, args: list[str], switch: str, stdin: str | None = None) -> subprocess.CompletedProcess:
        """``tool ARGS`` (ovs-ofctl, ovs-vsctl) where ``switch`` is."""
        server = self.server_of(switch)
        if server is None:
            return subprocess.run([tool, *args], input=stdin, capture_output=True, text=True, timeout=60)
        return _on(server, tool, args, stdin)

    # ------------------------------------------------------------------ while the run plays
    def nodes_on(self, server: str) -> list[str]:
        return sorted(n for n, where in self.placement.items() if where == server)

    def server_down(self, server: str, t: float) -> list[str]:
        """Lose the stand-in ``server``: every process in its namespaces killed (Open vSwitch, sshd,
        host shells, services); its network namespace stays, so its peers' TCP connections end with a
        reset and its tunnels lead nowhere. Returns the nodes that were on it."""
        target = self.servers[server]
        self.lost[server] = round(t, 6)
        stand_ins.kill_server(target.name)
        return self.nodes_on(server)

    def cpu_seconds(self) -> dict[str, float]:
        """CPU seconds of each live server's ovs-vswitchd (``ovs-vswitchd@<server>``)."""
        out = {}
        for name, server in self.servers.items():
            if name in self.lost:
                continue
            res = server.run(f"cat /proc/$(cat {OVS_PIDFILE})/stat", timeout=20)
            try:
                out[f"ovs-vswitchd@{name}"] = stat_cpu_seconds(res.stdout)
            except ValueError:
                continue
        return out

    # ------------------------------------------------------------------ the end
    def prune_lost(self, net) -> None:
        """Drop the lost servers' nodes and links from ``net`` before ``net.stop()``: their shells are
        gone, and a Mininet node's ``cmd`` waits for ever on a dead shell."""
        if not self.lost:
            return
        self.tunnels()  # as built, for the summary
        gone = {n for s in self.lost for n in self.nodes_on(s)}
        net.hosts = [h for h in net.hosts if h.name not in gone]
        net.switches = [s for s in net.switches if s.name not in gone]
        net.links = [lk for lk in net.links if lk.intf1.node.name not in gone and lk.intf2.node.name not in gone]
        for name in gone:
            net.nameToNode.pop(name, None)

    def remove(self) -> None:
        """Remove the stand-in servers this run made (never raises)."""
        if self.made:
            try:
                stand_ins.remove_servers()
            except Exception:  # noqa: BLE001 - teardown goes on; sdvisc clean finds what is left
                pass

    def tunnels(self) -> list[dict]:
        """The tunnels as built: a, b and VNI of each (kept once read: a lost server's are pruned)."""
        if self._tunnels is None and self.net is not None:
            self._tunnels = [{"a": lk.intf1.node.name, "b": lk.intf2.node.name, "vni": lk.vni}
                             for lk in self.net.links if isinstance(lk, RemoteVXLANLink) and lk.vni]
        return self._tunnels or []

    def describe(self) -> dict:
        """summary.json ``cluster``: the servers, where every node ran, the tunnels, the lost servers."""
        tunnels = self.tunnels()
        return {"servers": {n: {"address": s.ip, "emulated": self.made} for n, s in self.servers.items()},
                "head_ip": self.head_ip if self.servers else None, "placement": dict(sorted(self.placement.items())),
                "tunnel": self.spec.tunnel, "tunnels": tunnels, "lost": self.lost}


def set_link_by_shell(ends: list, up: bool) -> float:
    """Set a link's ends (Mininet interfaces; a tunnel's on two servers) up or down through their
    nodes' shells (``ip link set``; a switch's shell is its server's root namespace); returns the
    wall time before the first."""
    t_first = time.time()
    for intf in ends:
        out = intf.node.cmd(f"ip link set dev {intf.name} {'up' if up else 'down'}")
        if out.strip():
            raise OSError(f"{intf.node.name}: ip link set dev {intf.name}: {out.strip()}")
    return t_first
