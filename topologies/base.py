"""Shared pieces of the testbed topologies: addressing, switch classes and a static description.

Addressing is stable so that scenarios, tables and captures can name things:
turbine ``wt<c>_<n>`` has IP ``10.0.<c>.<n>/16`` and MAC ``02:00:00:00:<c>:<n>`` (hex);
service hosts (``owfcc``, ``sdc1``, ``sdc2``) live in ``10.0.0.0/24``. The SDN application
answers on a virtual IP (:data:`sdvisc.config.CONTROLLER_VIP`); hosts reach it through a static ARP
entry. Every switch sends packets for it to the controller as packet-ins, or — with an *intake
network* (:meth:`TestbedTopo.add_intake`) — forwards its own hosts' datagrams for it over a patch
port to the bridge ``sctl`` and the host ``ctl``, which owns the virtual IP and MAC and in whose
namespace the SDN app holds a UDP socket (the data network's view of a lab's controller PC).
"""

from __future__ import annotations

import os

from mininet.link import OVSLink
from mininet.node import Host, OVSBridge, OVSSwitch, RemoteController
from mininet.topo import Topo
from mininet.util import naturalSeq

from sdvisc.vocabulary import plant_index
from sdvisc.wire_layouts import PORT_TURBINE
from topologies.options import options_of

NET_PREFIX_LEN = 16
SERVICE_HOSTS = {
    "owfcc": ("10.0.0.10", "02:00:00:00:00:0a"),
    "sdc1": ("10.0.0.21", "02:00:00:00:00:15"),
    "sdc2": ("10.0.0.22", "02:00:00:00:00:16"),
}


def turbine_host(cluster: int, number: int) -> str:
    """Mininet host name of turbine ``number`` of ``cluster`` (both from 1)."""
    return f"wt{cluster}_{number}"


def turbine_ip(cluster: int, number: int) -> str:
    if not (1 <= cluster <= 254 and 1 <= number <= 254):
        raise ValueError(f"turbine wt{cluster}_{number}: cluster and number must be within 1..254")
    return f"10.0.{cluster}.{number}"


def turbine_mac(cluster: int, number: int) -> str:
    return f"02:00:00:00:{cluster:02x}:{number:02x}"


def kernel_datapath_available() -> bool:
    """True where the Open vSwitch kernel module is loaded (it forwards in microseconds)."""
    return os.path.isdir("/sys/module/openvswitch")


def default_datapath() -> str:
    """``kernel`` where the module is loaded, else ``user`` (the netdev userspace datapath)."""
    forced = os.environ.get("SDVISC_DATAPATH")
    if forced in ("kernel", "user"):
        return forced
    return "kernel" if kernel_datapath_available() else "user"


class TestbedSwitch(OVSSwitch):
    """An OpenFlow 1.3 Open vSwitch bridge on the best datapath this machine has."""

    def __init__(self, name, **params):
        params.setdefault("datapath", default_datapath())
        params.setdefault("protocols", "OpenFlow13")
        params.setdefault("failMode", "secure")
        super().__init__(name, **params)


class L2Switch(OVSBridge):
    """The prototype's non-OpenFlow L2 switch: a standalone learning bridge, no controller."""

    def __init__(self, name, **params):
        params.setdefault("datapath", default_datapath())
        super().__init__(name, **params)


class CheckedController(RemoteController):
    """Mininet's RemoteController without its telnet probe: the runner checks the port itself, and
    the probe can choke on the OpenFlow HELLO bytes os-ken sends back (UnicodeDecodeError)."""

    def checkListening(self):
        pass

    def stop(self, *args, **kwargs):
        """End the node's shell too (Mininet's RemoteController.stop does nothing, so the shell was
        left to the cleanup's 1 s SIGTERM grace at every run)."""
        self.terminate()


INTAKE_HOST = "ctl"
"""The intake network's host: it owns the controller's virtual IP and MAC."""
INTAKE_BRIDGE = "sctl"
"""The intake network's bridge: a patch port to every OpenFlow switch and one port to :data:`INTAKE_HOST`."""
INTAKE_BRIDGE_DPID = 0x5DC7000000000001
INTAKE_HOST_PORT = 1


class IntakeBridge(OVSSwitch):
    """The intake network's bridge: no controller, and flows of its own (:func:`intake_bridge_flows`)
    that send every frame from a switch to the intake host and drop whatever the host sends."""

    def __init__(self, name, **params):
        params.setdefault("datapath", default_datapath())
        params.setdefault("protocols", "OpenFlow13")
        params.setdefault("failMode", "secure")
        super().__init__(name, **params)

    def start(self, controllers):
        super().start([])
        if not self.batch:  # (else the bridge exists only after batchStartup)
            self.add_flows()

    @classmethod
    def batchStartup(cls, switches, **kwargs):  # noqa: N802 - Mininet's name
        started = super().batchStartup(switches, **kwargs)
        for switch in started:
            switch.add_flows()
        return started

    def add_flows(self) -> None:
        for flow in intake_bridge_flows():
            out = self.cmd("ovs-ofctl", "-O", "OpenFlow13", "add-flow", self.name, flow)
            if out.strip():
                raise RuntimeError(f"{self.name}: ovs-ofctl add-flow {flow}: {out.strip()}")


def intake_bridge_flows() -> list[str]:
    """ovs-ofctl flows of :class:`IntakeBridge`: one way only, from the switches to the host."""
    return [f"priority=10,in_port={INTAKE_HOST_PORT},actions=drop", f"priority=1,actions=output:{INTAKE_HOST_PORT}"]


class ImpairmentHost(Host):
    """The host of an impairment element (:mod:`impairment.element`): no IP address, no IPv6 and
    no ARP entries of its own, so that it never sends a frame of its own into the link."""

    def startShell(self, *args, **kwargs):
        super().startShell(*args, **kwargs)
        # before any interface is moved in: interfaces get this namespace's default (no IPv6)
        self.cmd("sysctl -qw net.ipv6.conf.all.disable_ipv6=1 net.ipv6.conf.default.disable_ipv6=1")

    def setARP(self, ip, mac):
        return ""


def element_name(index: int) -> str:
    """Host name of the ``index``-th impairment element (from 1); short, as interface names are
    limited to 15 characters (``imp12-eth1``)."""
    return f"imp{index}"


class TestbedTopo(Topo):
    """Base for the testbed topologies: helpers that add hosts with stable addresses.

    ``impaired``: switch-to-switch links ``(a, b)`` that get an impairment element: ``addLink(a, b)``
    then adds a host ``imp<k>`` (role ``impairment``) with interface ``-eth0`` toward ``a`` and
    ``-eth1`` toward ``b``, and links ``a – imp<k> – b``; the switches' port numbers stay those
    of the direct link, and :func:`describe` still shows one link ``a–b`` (with ``element``).
    """

    options_model = None
    """The topology's options (a :class:`topologies.options.TopologyOptions`); ``build`` gets its
    fields, validated (None: made from ``build``'s keyword arguments, topologies.options.options_of)."""

    def __init__(self, *args, impaired=(), **params):
        self.impaired = {frozenset(link) for link in impaired}
        self.elements: dict[str, tuple[str, str]] = {}  # element host -> (a, b)
        mininet_opts = {key: params.pop(key) for key in ("hopts", "sopts", "lopts") if key in params}
        model = options_of(type(self))
        if len(args) > len(model.model_fields):
            raise TypeError(f"{type(self).__name__} takes at most {len(model.model_fields)} options "
                            f"({', '.join(model.model_fields)}), {len(args)} given")
        positional = dict(zip(model.model_fields, args))  # (mn --topo farm,2,3: in the model's order)
        super().__init__(**mininet_opts, **model.model_validate({**positional, **params}).model_dump())

    def addLink(self, node1, node2, port1=None, port2=None, key=None, **opts):  # noqa: N802 - Mininet's name
        if frozenset((node1, node2)) not in self.impaired:
            return super().addLink(node1, node2, port1, port2, key, **opts)
        element = self.addHost(element_name(len(self.elements) + 1), cls=ImpairmentHost, ip=None,
                               role="impairment", a=node1, b=node2)
        self.elements[element] = (node1, node2)
        super().addLink(node1, element, port1, 0, **opts)
        return super().addLink(element, node2, 1, port2, **opts)

    def add_service_host(self, name: str) -> str:
        ip, mac = SERVICE_HOSTS[name]
        return self.addHost(name, ip=f"{ip}/{NET_PREFIX_LEN}", mac=mac, role="service")

    def add_turbine(self, cluster: int, number: int, plant: int | None = None) -> str:
        """Turbine host ``wt<cluster>_<number>``; ``plant``: its converter in the full plant model
        (default :func:`sdvisc.vocabulary.plant_index`)."""
        name = turbine_host(cluster, number)
        return self.addHost(
            name,
            ip=f"{turbine_ip(cluster, number)}/{NET_PREFIX_LEN}",
            mac=turbine_mac(cluster, number),
            role="turbine",
            cluster=cluster,
            number=number,
            plant_index=plant_index(cluster, number) if plant is None else plant,
        )

    def add_switch(self, name: str, dpid: int, openflow: bool = True) -> str:
        cls = TestbedSwitch if openflow else L2Switch
        return self.addSwitch(name, cls=cls, dpid=f"{dpid:016x}", openflow=openflow)

    def add_intake(self, ip: str, mac: str) -> None:
        """The intake network: host :data:`INTAKE_HOST` (``ip``, ``mac``: the controller's virtual
        addresses) on bridge :data:`INTAKE_BRIDGE`, patched to every OpenFlow switch. Not part of
        the farm's network: :func:`describe` lists it only as ``intake_ports``, so no path uses it."""
        self.addHost(INTAKE_HOST, ip=f"{ip}/{NET_PREFIX_LEN}", mac=mac, role="intake")
        self.addSwitch(INTAKE_BRIDGE, cls=IntakeBridge, dpid=f"{INTAKE_BRIDGE_DPID:016x}", role="intake")
        Topo.addLink(self, INTAKE_HOST, INTAKE_BRIDGE, port2=INTAKE_HOST_PORT)
        for name in [n for n in self.switches() if self.nodeInfo(n).get("openflow", True) and n != INTAKE_BRIDGE]:
            Topo.addLink(self, name, INTAKE_BRIDGE, cls=OVSLink)  # a patch port: no device, no syscall


_DELAY_UNITS = {"us": 1e-6, "ms": 1e-3, "s": 1.0}


def delay_seconds(delay) -> float:
    """A Mininet link's ``delay`` option (tc's ``'2ms'``, ``'500us'``, ``'1s'``; a bare number is
    microseconds, as tc reads it) in seconds; 0.0 for None."""
    if delay is None:
        return 0.0
    if isinstance(delay, int | float):
        return float(delay) * 1e-6
    text = str(delay).strip()
    for unit in ("us", "ms", "s"):  # ("s" last: "ms" and "us" end with it)
        if text.endswith(unit):
            return float(text[: -len(unit)]) * _DELAY_UNITS[unit]
    return float(text) * 1e-6


def describe(topo: Topo) -> dict:
    """A static, JSON-ready description of ``topo`` (the SDN app's view of the wiring).

    Returns ``{"switches": {name: {"dpid", "openflow"}}, "hosts": {name: {"ip", "mac", "role",
    "switch", "port", ...}}, "links": [{"a", "a_port", "b", "b_port"}]}`` where ``links`` lists
    switch-to-switch links only and host entries name the switch port they hang on (a turbine's also
    its ``cluster``, ``number``, ``plant_index`` (its converter in the full plant model) and ``udp_port``,
    here always ``PORT_TURBINE``); a link's ``delay_s`` is the Mininet link's ``delay`` option in seconds
    (0: none set, unknown); with an intake
    network also ``"intake_ports": {switch: port toward it}`` (its bridge and host are left out). A link with
    an impairment element is one link ``a–b`` between the switches' ports toward the element
    (plus ``"element": name``); the element is not a host of the description.
    """
    switches = {}
    for name in topo.switches():
        info = topo.nodeInfo(name)
        if info.get("role") != "intake":
            switches[name] = {"dpid": int(info["dpid"], 16), "openflow": bool(info.get("openflow", True))}
    hosts = {}
    links = []
    intake_ports = {}
    element_ports: dict[str, dict[str, int]] = {}  # element -> {switch: the switch's port toward it}
    element_delay: dict[str, float] = {}  # element -> the delay of its two halves, s
    for a, b, info in topo.links(sort=True, withKeys=False, withInfo=True):
        a, b = info["node1"], info["node2"]
        pa, pb = info["port1"], info["port2"]
        if INTAKE_BRIDGE in (a, b):
            if a in switches or b in switches:
                intake_ports.update({a: pa} if a in switches else {b: pb})
            continue
        if a in switches and b in switches:
            links.append({"a": a, "a_port": pa, "b": b, "b_port": pb, "delay_s": delay_seconds(info.get("delay"))})
            continue
        host, sw, sw_port = (a, b, pb) if b in switches else (b, a, pa)
        hinfo = topo.nodeInfo(host)
        if hinfo.get("role") == "impairment":
            element_ports.setdefault(host, {})[sw] = sw_port
            element_delay[host] = element_delay.get(host, 0.0) + delay_seconds(info.get("delay"))
            continue
        entry = {
            "ip": hinfo["ip"].split("/")[0],
            "mac": hinfo["mac"],
            "role": hinfo.get("role", "service"),
            "switch": sw,
            "port": sw_port,
        }
        if entry["role"] == "turbine":
            entry["cluster"] = hinfo["cluster"]
            entry["number"] = hinfo["number"]
            entry["udp_port"] = hinfo.get("udp_port", PORT_TURBINE)  # one host, one endpoint: the default
            entry["plant_index"] = hinfo.get("plant_index", plant_index(hinfo["cluster"], hinfo["number"]))
        hosts[host] = entry
    for element, ports in element_ports.items():
        info = topo.nodeInfo(element)
        a, b = info["a"], info["b"]
        links.append({"a": a, "a_port": ports[a], "b": b, "b_port": ports[b], "delay_s": element_delay[element],
                      "element": element})
    links.sort(key=lambda link: naturalSeq((link["a"], link["b"])))  # the order without elements
    desc = {"switches": switches, "hosts": hosts, "links": links}
    if intake_ports:
        desc["intake_ports"] = dict(sorted(intake_ports.items()))
    return desc
