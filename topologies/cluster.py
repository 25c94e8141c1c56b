"""The farm's network spread over several servers with Mininet's cluster mode (issue 30; docs/cluster.md).

Subclasses of Mininet's cluster classes (``mininet.examples.cluster``), not a fork:

* :class:`ServerMixin` — a ``RemoteMixin`` that reaches its server with the server's own ssh
  options (key, no prompts, no known-hosts file) and, as root, without ``sudo``;
  :class:`ServerHost` and :func:`server_class` (any project host or switch class made remote: a
  switch class also gets ``RemoteOVSSwitch``'s per-server batch start-up and shut-down).
  :class:`ServerSwitch` is :class:`topologies.base.TestbedSwitch` on a server: OpenFlow 1.3, fail-mode
  secure, on the server's own ``ovs-vswitchd`` (the userspace ``netdev`` datapath unless the server
  has the kernel module).
* :class:`RemoteVXLANLink` — ``RemoteGRELink`` with VXLAN instead of GRE (this kernel has no GRE):
  a link between nodes on two servers is a pair of kernel VXLAN devices, one VNI per link, UDP 4789
  between the servers' LAN addresses; every link of the network gets the tunnel's MTU (the LAN's
  MTU minus VXLAN's 50 bytes, at most 1500), so no host sends a frame a tunnel cannot carry.
* Placement: topologies/placers.py — :class:`FarmPlacer` (by farm cluster), :class:`RolePlacer` (by role),
  :class:`DictPlacer` (explicit), each usable as ``placement=`` (``functools.partial`` for options).
* :class:`ClusterNet` — a ``MininetCluster`` over :class:`host_tools.servers.Server` objects: it
  builds a project topology across the servers with those classes, its switches connecting to a
  controller on the head's LAN address.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
from functools import partial
from itertools import groupby
from operator import attrgetter

from mininet.examples.cluster import (
    ClusterCleanup,
    MininetCluster,
    RemoteLink,
    RemoteMixin,
    RemoteOVSSwitch,
)
from mininet.link import Link, OVSLink
from mininet.log import debug, info
from mininet.net import Mininet
from mininet.node import Host, Node, OVSSwitch
from mininet.util import quietRun

from host_tools.child_signals import bound_node_stops, default_signals, give_children_default_signals
from host_tools.servers import KEYDIR_PREFIX, Server, tunnel_mtu
from topologies.base import CheckedController, TestbedSwitch
from topologies.placers import FarmPlacer

VXLAN_PORT = 4789
"""The IANA VXLAN port: a firewall between real servers must pass UDP to it."""
OPENFLOW_PORT = 6653
HEAD = "localhost"
"""Mininet's name for this machine among a cluster's servers (``head=True``: nodes may stay here)."""


def head_address_towards(ip: str) -> str:
    """This machine's source address for ``ip`` (``ip route get``): the head's address on a server's LAN."""
    out = quietRun(f"ip route get {ip}")
    if " src " not in out:
        raise RuntimeError(f"no route from this machine to the server {ip}")
    return out.split(" src ")[1].split()[0]


class ServerMixin(RemoteMixin):
    """A ``RemoteMixin`` that reaches its server with ``ssh_options`` (the server's key and options,
    :func:`host_tools.servers.ssh_options`) and, as root on the server, without ``sudo``."""

    def __init__(self, name, ssh_options=None, **kwargs):
        self.ssh_options = list(ssh_options or [])
        super().__init__(name, **kwargs)
        # RemoteMixin registers "ssh user@server sudo mn -c" for mininet.clean.cleanup(); the
        # project's own clean-up (host_tools.cleanup, host_tools.servers) is the one used here
        ClusterCleanup.serveruser.pop(self.server, None)

    def server_ssh(self) -> list[str]:
        """``ssh OPTIONS -q -tt [control path] user@server`` (RemoteMixin's ``sshcmd`` shape: ``-tt``
        its own element, removed for ``popen``)."""
        cmd = ["ssh", *self.ssh_options, "-q", "-tt"]
        if self.controlPath:
            cmd += ["-o", "ControlPath=" + self.controlPath, "-o", "ControlMaster=auto", "-o", "ControlPersist=1"]
        return cmd + [self.dest]

    def startShell(self, *args, **kwargs):  # noqa: N802 - Mininet's name
        if self.isRemote:
            self.sshcmd = self.server_ssh()
        super().startShell(*args, **kwargs)

    @staticmethod
    def _ignoreSignal():  # noqa: N802 - Mininet's name (RemoteMixin's preexec_fn for a server node's ssh)
        """Its own process group (as RemoteMixin's), and the default signal dispositions: an ssh
        client that inherited an ignored SIGHUP (nohup) outlived Mininet's SIGHUP (issue 42)."""
        os.setpgrp()
        default_signals()

    def _popen(self, cmd, sudo=True, tt=True, **params):
        if not self.isRemote:  # on the head: a plain node's Popen. RemoteMixin's os.setpgrp would make the
            # process a group leader, so "mnexec -d" forks and its parent exits at once (a service seen as ended)
            return Node._popen(self, cmd.split() if isinstance(cmd, str) else cmd, **params)
        if self.user == "root":  # no "sudo -E" prefix
            sudo = False
        return super()._popen(cmd, sudo=sudo, tt=tt, **params)


class ServerHost(ServerMixin, Host):
    """A Mininet host on a server."""


class ServerSwitchMixin(ServerMixin):
    """What a project switch class needs on a server: no local Open vSwitch check (the servers are
    checked over ssh), and the server's datapath (``netdev`` unless it has the kernel module)."""

    _datapaths: dict[str, str] = {}
    _ovs_versions: dict[str, tuple[int, ...]] = {}

    def __init__(self, name, datapath=None, **params):
        super().__init__(name, datapath=datapath or "user", **params)
        if datapath is None:
            self.datapath = self.server_datapath()

    @classmethod
    def setup(cls):
        pass

    argmax = 3000
    """Characters per ``ovs-vsctl`` command of the batch start-up (Mininet's ``OVSSwitch.argmax`` is
    128,000): it is typed into the server's shell, a terminal in canonical mode whose lines end at
    4095 characters — a longer one is cut, and a server with four farm switches lost its bridges."""

    @classmethod
    def batchStartup(cls, switches, **_kwargs):  # noqa: N802 - Mininet's name
        """``RemoteOVSSwitch``'s per-server batches, in commands of at most :attr:`argmax` characters;
        then a bridge with flows of its own (the intake bridge, :class:`topologies.base.IntakeBridge`)
        gets them: its own ``batchStartup``, later in the method order, is not reached."""
        for _server, group in groupby(sorted(switches, key=attrgetter("server")), attrgetter("server")):
            group = tuple(group)
            OVSSwitch.batchStartup.__func__(cls, group, run=group[0].cmd)
        for switch in switches:
            if hasattr(switch, "add_flows"):
                switch.add_flows()
        return switches

    def isOldOVS(self):  # noqa: N802 - Mininet's name
        """RemoteOVSSwitch's check without distutils' StrictVersion (deprecated; gone in Python 3.12)."""
        if self.server not in self._ovs_versions:
            found = re.findall(r"\d+\.\d+", self.cmd("ovs-vsctl --version"))
            self._ovs_versions[self.server] = tuple(int(x) for x in found[0].split(".")) if found else (0,)
        return self._ovs_versions[self.server] < (1, 10)

    def server_datapath(self) -> str:
        if self.server not in self._datapaths:
            out = self.cmd("test -d /sys/module/openvswitch && echo kernel || echo user")
            self._datapaths[self.server] = "kernel" if "kernel" in out else "user"
        return self._datapaths[self.server]


_REMOTE_CLASSES: dict[type, type] = {}


def server_class(cls: type) -> type:
    """``cls`` (a Mininet host or Open vSwitch class of the project) made able to run on a server;
    one class per ``cls``, so that Mininet's batch start-up groups a class's switches together."""
    if issubclass(cls, ServerMixin):
        return cls
    if cls not in _REMOTE_CLASSES:
        if issubclass(cls, OVSSwitch):
            bases = (ServerSwitchMixin, RemoteOVSSwitch, cls) if cls is not OVSSwitch else (ServerSwitchMixin,
                                                                                          RemoteOVSSwitch)
        else:
            bases = (ServerMixin, cls)
        _REMOTE_CLASSES[cls] = type(f"Server{cls.__name__}", bases, {"__module__": __name__})
    return _REMOTE_CLASSES[cls]


ServerSwitch = server_class(TestbedSwitch)
""":class:`topologies.base.TestbedSwitch` on a server (OpenFlow13, fail-mode secure)."""


class RemoteVXLANLink(RemoteLink):
    """A link that is a VXLAN tunnel where its nodes are on different servers (``RemoteGRELink``'s
    scheme): on each side ``ip link add NAME type vxlan id VNI remote PEER local SELF dstport 4789``,
    moved into the node. One VNI per tunnel (a class counter). ``mtu``: every link end gets it (the
    tunnel's and, as ``RemoteGRELink`` does, a link within one server too), so a frame that fits a
    host's interface fits every tunnel; :class:`ClusterNet` passes the LAN's MTU minus 50."""

    VNI = 0
    DEFAULT_MTU = 1450

    def __init__(self, node1, node2, mtu=None, **kwargs):
        self.mtu = mtu or self.DEFAULT_MTU
        self.vni = None
        RemoteLink.__init__(self, node1, node2, **kwargs)

    def stop(self):
        if self.tunnel:
            self.intf1.delete()
            self.intf2.delete()
        else:
            Link.stop(self)
        self.tunnel = None

    def makeIntfPair(self, intfname1, intfname2, addr1=None, addr2=None,  # noqa: N802 - Mininet's name
                     node1=None, node2=None, deleteIntfs=True):
        node1 = self.node1 if node1 is None else node1
        node2 = self.node2 if node2 is None else node2
        if getattr(node1, "server", "localhost") == getattr(node2, "server", "localhost"):
            Link.makeIntfPair(intfname1, intfname2, addr1, addr2, node1, node2, deleteIntfs=deleteIntfs)
            if self.mtu != 1500:
                node1.cmd(f"ip link set dev {intfname1} mtu {self.mtu}")
                node2.cmd(f"ip link set dev {intfname2} mtu {self.mtu}")
        else:
            self.makeTunnel(node1, node2, intfname1, intfname2, addr1, addr2)
            self.tunnel = self.vni
        return None

    def makeTunnel(self, node1, node2, intfname1, intfname2, addr1=None, addr2=None):  # noqa: N802
        assert node1.server != node2.server
        if node2.server == "localhost":
            return self.makeTunnel(node2, node1, intfname2, intfname1, addr2, addr1)
        ip1, ip2 = node1.serverIP, node2.serverIP
        if node1.server == "localhost":  # the head's address toward the server, not 127.0.0.1
            ip1 = head_address_towards(ip2)
        type(self).VNI += 1
        self.vni = type(self).VNI
        debug(f"\n*** Make VXLAN tunnel VNI {self.vni} {node1.server}:{intfname1} == {node2.server}:{intfname2}")
        for node, intf, addr, local, remote in ((node1, intfname1, addr1, ip1, ip2), (node2, intfname2, addr2, ip2, ip1)):
            # one ssh round trip a side: delete a stale device, create, configure, move into the node
            # (a switch's node is the server's root namespace: nothing to move)
            cmd = (f"ip link delete {intf} 2>/dev/null; ip link add name {intf} type vxlan id {self.vni} "
                   f"remote {remote} local {local} dstport {VXLAN_PORT} && ip link set dev {intf}"
                   + (f" address {addr}" if addr else "") + f" mtu {self.mtu} up")
            if node.inNamespace:
                cmd += f" && ip link set {intf} netns {node.pid}"
            out = node.rcmd(cmd) if node.isRemote else subprocess.run(  # the head: rcmd would not use a shell
                ["sh", "-c", cmd], capture_output=True, text=True, timeout=30).stderr
            if out.strip():
                raise RuntimeError(f"error creating VXLAN {intf} on {node} ({node.server}): {out.strip()}")
        return None

    def status(self):
        return f"{Link.status(self)} {f'VXLAN VNI {self.vni}' if self.tunnel else 'OK'}"


# --- the network -----------------------------------------------------------------------------------------


class ClusterNet(MininetCluster):
    """A project topology across :class:`host_tools.servers.Server` s (real machines or those of
    :func:`host_tools.servers.make_servers`).

    ``placement``: a placer class (default :class:`FarmPlacer`; ``functools.partial`` for options);
    ``controller_ip`` (default: the head's LAN address) and ``controller_port``: where every
    OpenFlow switch connects (``controller=None``: no controller). Hosts, switches and links of the
    topology become their server variants (:func:`server_class`, :class:`RemoteVXLANLink`); an
    ``OVSLink`` (patch port) between switches on two servers becomes a tunnel.

    ``head``: this machine is a place too (:data:`HEAD`, first in the placers' server list), as in
    Mininet's own cluster examples; its nodes are local.

    ``ssh_multiplex``: the nodes of a server share one ssh connection (OpenSSH's ControlMaster, its
    socket in a private temporary directory), ended by :meth:`stop`.

    Unlike ``MininetCluster`` it makes no ``~/.ssh/mn`` directory and its pre-check runs ``true`` over
    ssh with the servers' options (no ``sudo`` for root)."""

    def __init__(self, servers: list[Server], topo=None, placement=None, controller_ip=None,
                 controller_port=OPENFLOW_PORT, lan_mtu=None, ssh_multiplex=False, head=False, **params):
        if not servers:
            raise ValueError("ClusterNet: no servers")
        give_children_default_signals()  # under nohup: the ssh clients and shells must not inherit SIG_IGN
        self.cluster_servers = {s.name: s for s in servers}
        self.servers = ([HEAD] if head else []) + [s.name for s in servers]
        self.serverIP = {s.name: s.ip for s in servers} | ({HEAD: "127.0.0.1"} if head else {})
        self.user = servers[0].user
        self.connections = {}
        self.placement = placement or FarmPlacer
        self.link_mtu = tunnel_mtu(lan_mtu or min(s.lan_mtu for s in servers))
        self.controller_ip = controller_ip or servers[0].head_ip
        self.control_dir = tempfile.mkdtemp(prefix=f"{KEYDIR_PREFIX}mux-") if ssh_multiplex else None
        if params.pop("precheck", True):
            self.precheck()
        params.setdefault("host", ServerHost)
        params.setdefault("switch", ServerSwitch)
        params.setdefault("link", RemoteVXLANLink)
        params.setdefault("controller", partial(CheckedController, ip=self.controller_ip, port=controller_port))
        params.setdefault("autoSetMacs", False)
        params.setdefault("waitConnected", False)
        Mininet.__init__(self, topo=topo, **params)

    def precheck(self):
        failed = []
        for server in self.cluster_servers.values():
            res = server.run("true", timeout=20)
            if res.returncode != 0:
                failed.append(f"{server.name} ({' '.join(server.ssh)}): {res.stderr.strip()}")
        if failed:
            raise RuntimeError("ClusterNet: server check failed: " + "; ".join(failed))

    def placeNodes(self):  # noqa: N802 - Mininet's name
        placement = self.placement
        self.placement = partial(placement, topo=self.topo)
        try:
            super().placeNodes()
        finally:
            self.placement = placement
        info("\n")
        for node in self.topo.nodes():
            config = self.topo.nodeInfo(node)
            server = self.cluster_servers.get(config.get("server"))
            if server is not None:
                config.setdefault("ssh_options", server.ssh_options)
                config.setdefault("user", server.user)
                if self.control_dir:
                    config.setdefault("controlPath", f"{self.control_dir}/%C")

    def stop(self):
        bound_node_stops(self)  # every node's shell: SIGHUP, SIGTERM, SIGKILL, each wait bounded
        try:
            super().stop()
        finally:
            if self.control_dir:
                for server in self.cluster_servers.values():
                    subprocess.run([*server.ssh[:-1], "-o", f"ControlPath={self.control_dir}/%C", "-O", "exit",
                                    server.dest], capture_output=True, timeout=20, stdin=subprocess.DEVNULL)
                shutil.rmtree(self.control_dir, ignore_errors=True)

    def placement_of(self) -> dict[str, str]:
        """node -> server name, as built."""
        return {n.name: n.server for n in (*self.hosts, *self.switches)}

    def addHost(self, name, cls=None, **params):  # noqa: N802 - Mininet's name
        return Mininet.addHost(self, name, cls=server_class(cls or self.host), **params)

    def addSwitch(self, name, cls=None, **params):  # noqa: N802 - Mininet's name
        return Mininet.addSwitch(self, name, cls=server_class(cls or self.switch), **params)

    def addLink(self, node1, node2, port1=None, port2=None, cls=None, **params):  # noqa: N802
        n1 = self[node1] if isinstance(node1, str) else node1
        n2 = self[node2] if isinstance(node2, str) else node2
        same = getattr(n1, "server", "localhost") == getattr(n2, "server", "localhost")
        if cls is None or cls is Link or (cls is OVSLink and not same):
            cls = self.link
        if isinstance(cls, type) and issubclass(cls, RemoteVXLANLink):
            params.setdefault("mtu", self.link_mtu)
        return Mininet.addLink(self, n1, n2, port1, port2, cls=cls, **params)
