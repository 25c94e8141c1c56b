"""Cluster mode's pieces that need no server: placement of the project's topologies, the tunnel MTU,
the server's ssh command (topologies/cluster.py, host_tools/servers.py)."""

from __future__ import annotations

from functools import partial

import pytest

from host_tools.servers import Server, ssh_options, tunnel_mtu
from topologies import base
from topologies.cluster import RemoteVXLANLink, ServerMixin, ServerSwitch, server_class
from topologies.farm import FarmTopo
from topologies.paper import PaperTopo
from topologies.placers import DictPlacer, FarmPlacer, RolePlacer

SERVERS = ["sdvisc-srv1", "sdvisc-srv2", "sdvisc-srv3"]


def place(topo, placer, servers=SERVERS) -> dict[str, str]:
    """What MininetCluster.placeNodes does with a placer (ClusterNet adds ``topo``)."""
    p = partial(placer, topo=topo)(servers=servers, nodes=topo.nodes(), hosts=topo.hosts(),
                                   switches=topo.switches(), links=topo.links())
    return {n: p.place(n) for n in topo.nodes()}


def test_farm_placer_puts_each_cluster_with_its_switch_and_the_core_on_the_last_server():
    placed = place(FarmTopo(clusters=5, turbines=2), FarmPlacer)
    for c in range(1, 6):
        want = SERVERS[(c - 1) % 3]
        assert placed[f"wt{c}_1"] == placed[f"wt{c}_2"] == placed[f"c{c}"] == want
    assert placed["sub1"] == placed["sub2"] == placed["owfcc"] == placed["sdc1"] == placed["sdc2"] == SERVERS[-1]


def test_farm_placer_tower_layout_and_paper():
    placed = place(FarmTopo(clusters=2, turbines=3, layout="tower"), FarmPlacer, SERVERS[:2])
    assert {placed[f"t1x{n}"] for n in range(1, 4)} == {SERVERS[0]}
    assert {placed[f"t2x{n}"] for n in range(1, 4)} == {SERVERS[1]}
    paper = place(PaperTopo(clusters=2, turbines=2), FarmPlacer, SERVERS[:2])
    assert paper["l2"] == paper["wt1_1"] == SERVERS[0]  # l2 carries both clusters: the lowest's server
    assert paper["wt2_1"] == SERVERS[1]
    assert {paper[s] for s in ("s1", "s2", "s3", "s4", "sdc1")} == {SERVERS[1]}


def test_farm_placer_core_option():
    placed = place(PaperTopo(clusters=1, turbines=2), partial(FarmPlacer, core=SERVERS[0]), SERVERS[:2])
    assert set(placed.values()) == {SERVERS[0]}


def test_role_placer():
    placed = place(PaperTopo(clusters=1, turbines=2), partial(RolePlacer, roles={"turbine": SERVERS[1],
                                                                             "service": SERVERS[2]}))
    assert placed["wt1_1"] == placed["wt1_2"] == placed["l2"] == SERVERS[1]
    assert placed["sdc1"] == placed["owfcc"] == placed["sdc2"] == SERVERS[2]
    assert placed["s1"] == placed["s2"] == SERVERS[2]
    assert placed["s3"] == placed["s4"] == SERVERS[0]  # no hosts: the default server


def test_dict_placer_hosts_follow_their_switch():
    placed = place(PaperTopo(clusters=1, turbines=2), partial(DictPlacer, placement={"s1": SERVERS[2], "l2": SERVERS[1]}))
    assert placed["s1"] == placed["sdc1"] == placed["owfcc"] == SERVERS[2]
    assert placed["l2"] == placed["wt1_1"] == SERVERS[1]
    assert placed["s2"] == placed["sdc2"] == SERVERS[0]


@pytest.mark.parametrize("lan, tunnel", [(1500, 1450), (1550, 1500), (9000, 1500), (1400, 1350)])
def test_tunnel_mtu(lan, tunnel):
    assert tunnel_mtu(lan) == tunnel


def test_server_ssh_command_uses_its_own_key_and_no_known_hosts():
    srv = Server(name="sdvisc-srv1", index=1, ip="10.250.0.11", key="/tmp/k/id_ed25519")
    assert srv.ssh[:3] == ["ssh", "-i", "/tmp/k/id_ed25519"]
    assert srv.ssh[-1] == "root@10.250.0.11"
    for opt in ("BatchMode=yes", "StrictHostKeyChecking=no", "UserKnownHostsFile=/dev/null"):
        assert opt in srv.ssh
    assert srv.ssh_options == ssh_options("/tmp/k/id_ed25519")


def test_server_classes():
    assert server_class(base.TestbedSwitch) is ServerSwitch
    for cls in (base.TestbedSwitch, base.L2Switch, base.IntakeBridge):
        remote = server_class(cls)
        assert issubclass(remote, cls) and issubclass(remote, ServerMixin)
        assert hasattr(remote, "batchStartup") and server_class(remote) is remote
    host = server_class(base.ImpairmentHost)
    assert issubclass(host, base.ImpairmentHost) and issubclass(host, ServerMixin) and not hasattr(host, "batchStartup")
    assert RemoteVXLANLink.DEFAULT_MTU == 1450
