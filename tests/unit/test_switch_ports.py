"""The switch-port type of a run (scenarios/switch_ports.py): the one ovs-vsctl transaction, and
reading Open vSwitch's Interface table for ports not (yet) open as asked — without switches."""

from __future__ import annotations

import pytest

from scenarios import switch_ports
from scenarios.loader import ScenarioError, load_scenario


def test_one_transaction_sets_every_port_and_system_is_the_empty_type():
    cmd = switch_ports.set_type_command(["s1-eth1", "s2-eth3"], "afxdp")
    assert cmd == ["ovs-vsctl", "--", "set", "Interface", "s1-eth1", "type=afxdp",
                   "--", "set", "Interface", "s2-eth3", "type=afxdp"]
    assert switch_ports.set_type_command(["s1-eth1"], "system")[-1] == 'type=""'


def _listing(*rows):
    return {"headings": ["name", "type", "error", "ofport"], "data": [list(r) for r in rows]}


def test_ports_not_ready_say_why_and_ready_ones_are_not_listed():
    empty = ["set", []]
    listing = _listing(["s1-eth1", "afxdp", empty, 1],  # open as asked
                       ["s1-eth2", "", empty, 2],  # still a system port
                       ["s2-eth1", "afxdp", "could not open network device s2-eth1 (Address family not supported)", -1],
                       ["s2-eth2", "afxdp", empty, empty])  # no OpenFlow port number yet
    got = switch_ports.not_ready(listing, ["s1-eth1", "s1-eth2", "s2-eth1", "s2-eth2", "s3-eth1"], "afxdp")
    assert set(got) == {"s1-eth2", "s2-eth1", "s2-eth2", "s3-eth1"}
    assert got["s1-eth2"] == "type system" and "Address family not supported" in got["s2-eth1"]
    assert got["s2-eth2"].startswith("no OpenFlow") and got["s3-eth1"] == "not in the Interface table"
    assert switch_ports.not_ready(_listing(["s1-eth1", "", empty, 1]), ["s1-eth1"], "system") == {}


def test_an_unknown_port_type_is_refused_before_touching_anything():
    with pytest.raises(ValueError, match="system, afxdp, afxdp-nonpmd"):
        switch_ports.use(["s1-eth1"], "dpdk")
    assert switch_ports.use([], "afxdp") == {"requested": "afxdp", "used": "afxdp", "ports": 0}


def test_the_scenario_key_is_checked_with_file_line_and_key(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("name: x\nduration_s: 1\nswitch_ports: dpdk\n")
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    text = str(err.value)
    assert "bad.yaml:3: switch_ports:" in text and "afxdp-nonpmd" in text  # file, line, key, what was expected
    path.write_text("name: x\nduration_s: 1\nswitch_ports: afxdp\n")
    assert load_scenario(path).switch_ports == "afxdp"
