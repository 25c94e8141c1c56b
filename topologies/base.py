"""Shared pieces of the testbed topologies: addressing, switch classes and a static description.

Addressing is stable so that scenarios, tables and captures can name things:
turbine ``wt<c>_<n>`` has IP ``10.0.<c>.<n>/16`` and MAC ``02:00:00:00:<c>:<n>`` (hex);
service hosts (``owfcc``, ``sdc1``, ``sdc2``) live in ``10.0.0.0/24``. The SDN application
answers on a virtual IP (:data:`sdvisc.config.CONTROLLER_VIP`) that no host owns; hosts reach it through a
static ARP entry, and every switch sends packets for it to the controller.
"""

from __future__ import annotations

import os

from mininet.node import OVSBridge, OVSSwitch
from mininet.topo import Topo

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


class TestbedTopo(Topo):
    """Base for the testbed topologies: helpers that add hosts with stable addresses."""

    def add_service_host(self, name: str) -> str:
        ip, mac = SERVICE_HOSTS[name]
        return self.addHost(name, ip=f"{ip}/{NET_PREFIX_LEN}", mac=mac, role="service")

    def add_turbine(self, cluster: int, number: int) -> str:
        name = turbine_host(cluster, number)
        return self.addHost(
            name,
            ip=f"{turbine_ip(cluster, number)}/{NET_PREFIX_LEN}",
            mac=turbine_mac(cluster, number),
            role="turbine",
            cluster=cluster,
            number=number,
        )

    def add_switch(self, name: str, dpid: int, openflow: bool = True) -> str:
        cls = TestbedSwitch if openflow else L2Switch
        return self.addSwitch(name, cls=cls, dpid=f"{dpid:016x}", openflow=openflow)


def describe(topo: Topo) -> dict:
    """A static, JSON-ready description of ``topo`` (the SDN app's view of the wiring).

    Returns ``{"switches": {name: {"dpid", "openflow"}}, "hosts": {name: {"ip", "mac", "role",
    "switch", "port", ...}}, "links": [{"a", "a_port", "b", "b_port"}]}`` where ``links`` lists
    switch-to-switch links only and host entries name the switch port they hang on.
    """
    switches = {}
    for name in topo.switches():
        info = topo.nodeInfo(name)
        switches[name] = {"dpid": int(info["dpid"], 16), "openflow": bool(info.get("openflow", True))}
    hosts = {}
    links = []
    for a, b, info in topo.links(sort=True, withKeys=False, withInfo=True):
        a, b = info["node1"], info["node2"]
        pa, pb = info["port1"], info["port2"]
        if a in switches and b in switches:
            links.append({"a": a, "a_port": pa, "b": b, "b_port": pb})
            continue
        host, sw, sw_port = (a, b, pb) if b in switches else (b, a, pa)
        hinfo = topo.nodeInfo(host)
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
        hosts[host] = entry
    return {"switches": switches, "hosts": hosts, "links": links}
