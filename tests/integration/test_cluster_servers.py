"""Issue 30's infrastructure: stand-in servers on this machine (host_tools/servers.py) and the farm's
network across them with Mininet's cluster mode over VXLAN (topologies/cluster.py). Everything on a
server is reached over ssh, as on a real machine. No timing is asserted."""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
import time

import pytest

from host_tools import servers
from host_tools.cleanup import leftovers
from host_tools.servers import make_servers, remove_servers
from tests.integration.helpers import ROOT
from topologies.base import SERVICE_HOSTS, describe
from topologies.cluster import VXLAN_PORT, ClusterNet
from topologies.paper import PaperTopo

pytestmark = pytest.mark.network

UDP_PORT = 5999
PAYLOAD = 1400  # a 1442-byte frame: fits the 1450-byte MTU every link gets over a 1500-byte LAN


def assert_servers_gone() -> None:
    left = leftovers()
    assert left["servers"] == [], f"servers left behind: {left['servers']}"
    assert not [n for n in left["netns"] if n.startswith(servers.NETNS_PREFIX)]
    assert servers.server_netns() == [] and servers.lan_netns() == [] and servers.key_dirs() == []
    assert servers.server_links() == []


def root_ovs(*args: str) -> str:
    return subprocess.run(["ovs-vsctl", "--timeout=10", *args], capture_output=True, text=True, timeout=20).stdout


def test_two_servers_each_run_their_own_open_vswitch_and_leave_nothing():
    srv = make_servers(2)
    try:
        assert [s.name for s in srv] == ["sdvisc-srv1", "sdvisc-srv2"]
        assert srv[0].ip != srv[1].ip
        uuids = [s.run("ovs-vsctl --timeout=10 get Open_vSwitch . _uuid", check=True).stdout.strip() for s in srv]
        assert len({*uuids, root_ovs("get", "Open_vSwitch", ".", "_uuid").strip()}) == 3  # three databases
        pids = [s.run("cat /run/openvswitch/ovs-vswitchd.pid", check=True).stdout.strip() for s in srv]
        assert pids[0] != pids[1]
        for s, pid in zip(srv, pids):  # the daemon lives in the server's network namespace
            assert int(pid) in [int(p) for p in subprocess.run(["ip", "netns", "pids", s.name], capture_output=True,
                                                               text=True).stdout.split()]
            assert s.run("hostname", check=True).stdout.strip() == s.name
            assert s.ip in s.run("ip -o -4 addr show dev eth0", check=True).stdout
        srv[0].run("ovs-vsctl --timeout=10 add-br sdvtest0 -- set bridge sdvtest0 datapath_type=netdev", check=True)
        assert "sdvtest0" in srv[0].run("ovs-vsctl --timeout=10 list-br", check=True).stdout.split()
        assert "sdvtest0" not in srv[1].run("ovs-vsctl --timeout=10 list-br", check=True).stdout.split()
        assert "sdvtest0" not in root_ovs("list-br").split()
        assert "sdvtest0" not in srv[1].run("ovs-vsctl --timeout=10 show", check=True).stdout
        srv[0].run(f"ping -c 1 -W 5 {srv[1].ip}", check=True)  # the LAN joins them
        srv[1].run(f"ping -c 1 -W 5 {srv[0].head_ip}", check=True)  # and the head
        assert leftovers()["servers"]  # reported while they run
    finally:
        removed = remove_servers()
    assert any(r.startswith("process") and "ovs-vswitchd" in r for r in removed)
    assert_servers_gone()


def _port_block(show: str, port: str) -> str | None:
    """The lines of ``port`` in ``ovs-ofctl show`` output (None: no such port)."""
    m = re.search(rf"^ *\d+\({re.escape(port)}\):.*?(?=^ *\d+\(|^ *LOCAL\(|^OFPT_GET_CONFIG|\Z)", show, re.S | re.M)
    return m.group(0) if m else None


def _wait_port_down(server, switch: str, port: str, timeout_s: float = 20) -> str:
    deadline = time.monotonic() + timeout_s
    while True:
        show = server.run(f"ovs-ofctl -O OpenFlow13 show {switch}", check=True).stdout
        block = _port_block(show, port)
        if block is None or "LINK_DOWN" in block or time.monotonic() > deadline:
            return show
        time.sleep(0.2)


def test_paper_topology_across_two_servers_carries_udp_over_a_vxlan_tunnel():
    srv = make_servers(2)
    by_name = {s.name: s for s in srv}
    net = None
    try:
        topo = PaperTopo(clusters=1, turbines=2)
        desc = describe(topo)
        net = ClusterNet(srv, topo=topo)  # by farm cluster: wt1_*, l2 on srv1; s1-s4 and the services on srv2
        net.start()
        placed = net.placement_of()
        assert placed["wt1_1"] == placed["l2"] == srv[0].name
        assert placed["s3"] == placed["s1"] == placed["sdc1"] == srv[1].name
        tunnels = [link for link in net.links if link.tunnel]
        assert {frozenset((lk.intf1.node.name, lk.intf2.node.name)) for lk in tunnels} == {
            frozenset(("l2", "s3")), frozenset(("l2", "s4"))}
        assert len({lk.vni for lk in tunnels}) == 2  # one VNI per link
        (link,) = [lk for lk in tunnels if {lk.intf1.node.name, lk.intf2.node.name} == {"l2", "s3"}]
        ends = {lk.node.name: lk.name for lk in (link.intf1, link.intf2)}
        for node, intf in ends.items():  # each end a kernel VXLAN device on its server, seen over ssh
            out = by_name[placed[node]].run(f"ip -d link show {intf}", check=True).stdout
            assert f"vxlan id {link.vni} " in out and f"dstport {VXLAN_PORT}" in out and "mtu 1450" in out
        for name in ("s1", "s3"):  # the project's switch settings on the server's own ovs-vswitchd
            conf = by_name[placed[name]].run(f"ovs-vsctl --timeout=10 get bridge {name} fail_mode protocols "
                                             "datapath_type", check=True).stdout.split()
            assert conf == ["secure", "[OpenFlow13]", "netdev"]
            target = by_name[placed[name]].run(f"ovs-vsctl --timeout=10 get-controller {name}", check=True).stdout
            assert target.strip() == f"tcp:{srv[0].head_ip}:6653"

        # wt1_1 -> l2 (learning bridge, floods to s3 and s4) -> tunnel -> s3 -> s1 -> sdc1; the OpenFlow
        # switches are fail-mode secure without a controller: flows for this path only (s4 drops)
        port = {(lk["a"], lk["b"]): lk["a_port"] for lk in desc["links"]}
        port.update({(lk["b"], lk["a"]): lk["b_port"] for lk in desc["links"]})
        flows = {"s3": f"in_port={port[('s3', 'l2')]},actions=output:{port[('s3', 's1')]}",
                 "s1": f"in_port={port[('s1', 's3')]},actions=output:{desc['hosts']['sdc1']['port']}"}
        for name, flow in flows.items():
            by_name[placed[name]].run(f"ovs-ofctl -O OpenFlow13 add-flow {name} {flow}", check=True)
        wt, sdc1 = net["wt1_1"], net["sdc1"]
        sdc1_ip, sdc1_mac = SERVICE_HOSTS["sdc1"]
        for host in (wt, sdc1):
            host.cmd(f"ethtool -K {host.defaultIntf()} tx off > /dev/null")  # the userspace datapath's UDP rule
        wt.cmd(f"ip neigh replace {sdc1_ip} lladdr {sdc1_mac} dev {wt.defaultIntf()} nud permanent")
        out = sdc1.cmd("mktemp").strip()
        receiver = ("import socket; s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM); "
                    f"s.bind(('0.0.0.0', {UDP_PORT})); s.settimeout(30); d, a = s.recvfrom(4096); "
                    "print(len(d), a[0], d[:6].decode())")
        sdc1.cmd(f"python3 -c {shlex.quote(receiver)} > {out} 2>&1 &")
        sender = ("import socket, time; s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM); "
                  f"[(s.sendto(b'sdvisc' + bytes({PAYLOAD - 6}), ('{sdc1_ip}', {UDP_PORT})), time.sleep(0.2)) "
                  "for _ in range(50)]")  # one line: the node's shell reads line by line
        wt.cmd(f"python3 -c {shlex.quote(sender)} > /dev/null 2>&1 &")
        sdc1.cmd("wait")  # the receiver: one datagram, or its 30 s timeout
        got = sdc1.cmd(f"cat {out}; rm -f {out}").split()
        wt.cmd("kill %1 2>/dev/null; wait")
        assert got[:3] == [str(PAYLOAD), wt.IP(), "sdvisc"], f"sdc1 received: {got}"

        # the tunnel taken down: the switch on each side reports its port down (over ssh)
        net.configLinkStatus("l2", "s3", "down")
        for node, intf in ends.items():
            show = _wait_port_down(by_name[placed[node]], node, intf)
            block = _port_block(show, intf)
            assert block is None or "LINK_DOWN" in block, f"{node} on {placed[node]}: {intf} not down:\n{show}"
        net.configLinkStatus("l2", "s3", "up")
        show = by_name[placed["s3"]].run("ovs-ofctl -O OpenFlow13 show s3", check=True).stdout
        deadline = time.monotonic() + 20
        while "LINK_DOWN" in (_port_block(show, ends["s3"]) or "") and time.monotonic() < deadline:
            time.sleep(0.2)
            show = by_name[placed["s3"]].run("ovs-ofctl -O OpenFlow13 show s3", check=True).stdout
        assert "LINK_DOWN" not in (_port_block(show, ends["s3"]) or "LINK_DOWN"), show
    finally:
        try:
            if net is not None:
                net.stop()
        finally:
            remove_servers()
    assert_servers_gone()


def test_servers_of_a_live_process_are_spared_and_those_of_a_dead_one_are_leftovers():
    maker = subprocess.Popen([sys.executable, "-c", "import sys, time; from host_tools.servers import make_servers; "
                              "make_servers(1); print('up', flush=True); time.sleep(120)"],
                             cwd=ROOT, stdout=subprocess.PIPE, text=True)
    try:
        assert maker.stdout.readline().strip() == "up"
        assert servers.owner() == maker.pid
        assert leftovers()["servers"] == [] and servers.remove_servers(leftovers_only=True) == []
        assert servers.leftovers(include_in_use=True)  # they are there, in use
        assert not servers.protected_pids().isdisjoint(p for p, _ in servers.server_processes())
    finally:
        maker.kill()
        maker.wait()
    assert servers.owner() is None  # the maker died without removing them: leftovers
    left = leftovers()["servers"]
    assert "netns sdvisc-srv1" in left and any("ovs-vswitchd" in item for item in left)
    removed = servers.remove_servers(leftovers_only=True)  # what sdvisc clean calls first
    assert "netns sdvisc-srv1" in removed
    assert_servers_gone()
