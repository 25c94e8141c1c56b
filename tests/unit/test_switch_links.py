"""Patch links (scenarios/switch_links.py): the ovs-vsctl transaction that fails and restores one, and
the scenario key. The network behaviour is tested in tests/integration/test_switch_ports.py."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from scenarios import switch_links
from scenarios.schema import Scenario


class End(SimpleNamespace):
    __hash__ = object.__hash__


def patch_link():
    s1, s3 = SimpleNamespace(name="s1", ports={}), SimpleNamespace(name="s3", ports={})
    a, b = End(name="s1-eth2", node=s1), End(name="s3-eth1", node=s3)
    s1.ports[a], s3.ports[b] = 2, 1
    return [a, b]


def test_a_failed_patch_link_is_both_ports_removed_in_one_transaction():
    cmd = switch_links.patch_link_command(patch_link(), up=False)
    assert cmd == ["ovs-vsctl", "--if-exists", "del-port", "s1", "s1-eth2", "--", "--if-exists", "del-port", "s3", "s3-eth1"]


def test_a_restored_patch_link_gets_its_peers_and_openflow_port_numbers_back():
    cmd = switch_links.patch_link_command(patch_link(), up=True)
    assert cmd.count("ovs-vsctl") == 1
    text = " ".join(cmd)
    assert "add-port s1 s1-eth2 -- set Interface s1-eth2 type=patch options:peer=s3-eth1 ofport_request=2" in text
    assert "add-port s3 s3-eth1 -- set Interface s3-eth1 type=patch options:peer=s1-eth2 ofport_request=1" in text


def test_is_patch_tells_the_ends_of_a_patch_link_from_veths():
    from mininet.link import Intf, OVSIntf

    assert switch_links.is_patch(OVSIntf.__new__(OVSIntf))
    assert not switch_links.is_patch(Intf.__new__(Intf))


def test_the_scenario_key_takes_veth_or_patch_only():
    assert Scenario.model_validate({"name": "x", "duration_s": 1.0}).switch_links == "veth"
    assert Scenario.model_validate({"name": "x", "duration_s": 1.0, "switch_links": "patch"}).switch_links == "patch"
    with pytest.raises(ValueError, match="switch_links"):
        Scenario.model_validate({"name": "x", "duration_s": 1.0, "switch_links": "fibre"})
