"""Topologies: names and addresses are stable, and no single switch-to-switch link failure cuts a
turbine off from either SDC."""

from __future__ import annotations

import networkx as nx
import pytest

from topologies import topos
from topologies.base import describe, turbine_ip, turbine_mac

CASES = [
    ("paper", {}),
    ("paper", {"clusters": 5, "turbines": 1}),
    ("farm", {}),
    ("farm", {"clusters": 3, "turbines": 4, "layout": "tower"}),
    ("farm", {"clusters": 5, "turbines": 10, "layout": "tower"}),
]


def graph_of(desc: dict) -> nx.Graph:
    g = nx.Graph()
    for link in desc["links"]:
        g.add_edge(link["a"], link["b"])
    for name, h in desc["hosts"].items():
        g.add_edge(name, h["switch"])
    return g


@pytest.mark.parametrize(("name", "params"), CASES)
def test_single_link_failure_leaves_a_path(name, params):
    desc = describe(topos[name](**params))
    g = graph_of(desc)
    turbines = [h for h, v in desc["hosts"].items() if v["role"] == "turbine"]
    assert turbines
    for link in desc["links"]:
        cut = g.copy()
        cut.remove_edge(link["a"], link["b"])
        for sdc in ("sdc1", "sdc2"):
            for wt in turbines:
                assert nx.has_path(cut, sdc, wt), f"{name} {params}: {link['a']}-{link['b']} down cuts {wt} from {sdc}"


def test_farm_default_is_5x10_compact_with_stable_addresses():
    desc = describe(topos["farm"]())
    turbines = {h: v for h, v in desc["hosts"].items() if v["role"] == "turbine"}
    assert len(turbines) == 50
    assert set(desc["switches"]) == {"sub1", "sub2", "c1", "c2", "c3", "c4", "c5"}
    assert turbines["wt5_10"]["ip"] == turbine_ip(5, 10) == "10.0.5.10"
    assert turbines["wt5_10"]["mac"] == turbine_mac(5, 10) == "02:00:00:00:05:0a"
    assert turbines["wt3_7"]["switch"] == "c3"
    assert len({v["ip"] for v in desc["hosts"].values()}) == len(desc["hosts"])
    assert len({s["dpid"] for s in desc["switches"].values()}) == len(desc["switches"])


def test_paper_has_four_openflow_switches_and_one_l2():
    desc = describe(topos["paper"]())
    of = [n for n, s in desc["switches"].items() if s["openflow"]]
    assert sorted(of) == ["s1", "s2", "s3", "s4"]
    assert [n for n, s in desc["switches"].items() if not s["openflow"]] == ["l2"]
    assert {"owfcc", "sdc1", "sdc2"} <= set(desc["hosts"])


def test_interface_names_fit_linux_limit():
    desc = describe(topos["farm"](clusters=9, turbines=20, layout="tower"))
    for name in list(desc["switches"]) + list(desc["hosts"]):
        assert len(f"{name}-eth99") <= 15
