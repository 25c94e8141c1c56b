"""Real devices in a scenario (scenarios/external_spec.py, scenarios/external.py): the keys are checked
against the topology with file, line and key named, every problem at once; and the topology a run
builds without the devices still gives the SDN app the whole network (pure: Mininet's Topo objects,
no root, no switch)."""

from __future__ import annotations

from pathlib import Path

import pytest

from scenarios.external import ExternalDevices
from scenarios.loader import ScenarioError, load_scenario
from topologies import topos
from topologies.base import describe

ROOT = Path(__file__).resolve().parents[2]
BASE = "name: t\nduration_s: 3\ntime_scale: 2\n"
PAPER = "topology: {name: paper, clusters: 1, turbines: 2}\n"
PEER = ("plant:\n  model: external\n  peer: {switch: l2, ip: 10.0.9.1, mac: '02:00:00:00:09:01', "
        "turbines: {wt1_1: 50101, wt1_2: 50102}}\n")


def problems(tmp_path, text: str) -> str:
    path = tmp_path / "s.yaml"
    path.write_text(BASE + text)
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    return str(err.value)


@pytest.mark.parametrize(("body", "key", "expect"), [
    (PAPER.replace("}", ", external_switches: {s9: {}}}"), "topology.external_switches.s9", "no switch 's9'"),
    (PAPER.replace("}", ", external_switches: {l2: {}}}"), "topology.external_switches.l2", "not an OpenFlow switch"),
    (PAPER.replace("}", ", external_switches: {s1: {}}}"), "topology.external_switches.s1",
     "hosts hang on s1 (owfcc, sdc1)"),
    (PAPER.replace("}", ", external_switches: {s3: {emulate: false, interfaces: {s1: eth1}}}}"),
     "topology.external_switches.s3.interfaces", "needs the interface toward l2"),
    (PAPER.replace("}", ", external_switches: {s3: {interfaces: {owfcc: eth1}}}}"),
     "topology.external_switches.s3.interfaces.owfcc", "not a neighbour of s3"),
    (PAPER + PEER.replace("switch: l2", "switch: s9"), "plant.peer.switch", "no switch 's9'"),
    (PAPER + PEER.replace("10.0.9.1", "10.0.0.21"), "plant.peer.ip", "sdc1's address"),
    (PAPER + PEER.replace("10.0.9.1", "192.168.1.5"), "plant.peer.ip", "10.0.0.0/16"),
    (PAPER + PEER.replace("50102", "50101"), "plant.peer", "a port of its own"),
    (PAPER + PEER.replace("}}\n", "}, emulate: false}\n"), "plant.peer", "needs interface"),
    (PAPER + "plant: {model: external}\n", "plant", "needs plant.peer"),
    (PAPER + PEER + "timeline:\n  - {t: 1.0, do: fault, duration_s: 0.1}\n", "timeline.0.do",
     "takes no commands from the testbed"),
    (PAPER + PEER.replace("}}\n", "}, emulate: false, interface: eth1}\n"), "(top level)",
     "time_scale must be 1"),
    (PAPER + PEER + "timeline:\n  - {t: 1.0, do: fuzz, host: wt1_2, targets: [sdc1], count: 10, duration_s: 1}\n",
     "timeline.0.host", "a turbine of the external peer"),
])
def test_a_bad_device_key_is_named_with_what_was_expected(tmp_path, body, key, expect):
    text = problems(tmp_path, body)
    assert f": {key}:" in text and expect in text, text


def test_auto_time_scale_is_refused_with_a_real_switch(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text("name: t\nduration_s: 3\ntime_scale: auto\n" + PAPER.replace(
        "}", ", external_switches: {s3: {emulate: false, interfaces: {s1: a, s2: b, s4: c, l2: d}}}}"))
    with pytest.raises(ScenarioError, match="not this machine's"):
        load_scenario(path)
    path.write_text(path.read_text().replace("emulate: false", "emulate: true"))
    assert load_scenario(path).time_scale == "auto"  # an emulated one takes the probe flows


def test_every_device_problem_is_reported_at_once(tmp_path):
    text = problems(tmp_path, PAPER.replace("}", ", external_switches: {s9: {}, l2: {}}}")
                    + PEER.replace("switch: l2", "switch: s8"))
    assert text.count("\n") >= 2 and "s9" in text and "l2 is not an OpenFlow" in text and "s8" in text


def test_the_shipped_device_scenarios_load():
    assert load_scenario(ROOT / "scenarios/external_peer.yaml").plant.peer.framing == "native"
    assert "s3" in load_scenario(ROOT / "scenarios/external_switch.yaml").topology.external_switches


def test_detaching_keeps_the_apps_view_and_hands_the_devices_their_ports():
    """The external switch and the card's turbines leave Mininet's topology; the app's description
    keeps every switch, datapath id, port and link, and lists the card's turbines on the card's port."""
    sc = load_scenario(ROOT / "scenarios/external_peer.yaml").model_copy(deep=True)
    sc.topology = sc.topology.model_validate({**sc.topology.model_dump(), "external_switches": {"s3": {}}})
    topo = topos[sc.topology.name](**sc.topology.params())
    whole = describe(topo)
    devices = ExternalDevices(sc)
    desc = devices.detach(topo, whole)
    assert desc["switches"] == whole["switches"] and desc["links"] == whole["links"]
    assert "s3" not in topo.g.node and "wt1_1" not in topo.g.node and "wt1_2" not in topo.g.node
    assert "s3" not in topo.ports and all("s3" not in [peer for peer, _ in ports.values()]
                                          for ports in topo.ports.values())
    s3_links = [lk for lk in whole["links"] if "s3" in (lk["a"], lk["b"])]
    # every s3 link: the Mininet side at its old port, the bridge side at s3's port
    by_switch = {(sw, port) for sw, port, _ in devices.attachments}
    for lk in s3_links:
        other, port = (lk["b"], lk["b_port"]) if lk["a"] == "s3" else (lk["a"], lk["a_port"])
        assert (other, port) in by_switch
    assert sorted(devices.bridges["s3"].ports) == sorted(lk["a_port"] if lk["a"] == "s3" else lk["b_port"]
                                                         for lk in s3_links)
    card = {n: desc["hosts"][n] for n in ("wt1_1", "wt1_2")}
    assert {h["ip"] for h in card.values()} == {"10.0.9.1"} and {h["switch"] for h in card.values()} == {"l2"}
    assert {h["port"] for h in card.values()} == {devices.peer_port} and devices.peer_port not in topo.ports["l2"]
    assert [h["udp_port"] for h in card.values()] == [50101, 50102]
    mininet_end, card_end = devices.veths[-1]  # the card's end goes into its namespace
    assert card_end == devices.peer_intf and ("l2", devices.peer_port, mininet_end) in devices.attachments
    assert {lk for lk in map(frozenset, [("s1", "s3"), ("s2", "s3"), ("s3", "s4"), ("l2", "s3")])} == set(devices.links)
