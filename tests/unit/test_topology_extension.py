"""Topologies as an extension point (issue 41): the names of ``topologies.topos`` are the only list
a scenario is checked against; each topology's options are its own pydantic model, a scenario's
mistakes in them named by file, line and key; ``topology.custom`` takes a file as ``mn --custom``
does; each turbine's plant converter and each link's delay are written once, in the description.
Pure: no network."""

from __future__ import annotations

import json
import textwrap

import networkx as nx
import pytest

from plant.params import PlantParams
from plant.service.run_record import plant_indices
from scenarios import configs
from scenarios.loader import ScenarioError, load_scenario
from topologies import topos
from topologies.base import delay_seconds, describe

CUSTOM = '''
from topologies.base import TestbedTopo
from topologies.options import ClusteredOptions


class LineTopo(TestbedTopo):
    """owfcc, sdc1 on x1; sdc2 on x2; one cluster's turbines on x2; converters from 7 on."""

    options_model = ClusteredOptions

    def build(self, clusters, turbines):
        x1, x2 = self.add_switch("x1", dpid=1), self.add_switch("x2", dpid=2)
        self.addLink(x1, x2, delay="3ms")
        for name, switch in (("owfcc", x1), ("sdc1", x1), ("sdc2", x2)):
            self.addLink(self.add_service_host(name), switch)
        for n in range(1, turbines + 1):
            self.addLink(self.add_turbine(1, n, plant=6 + n), x2)


topos = {"line": LineTopo}
'''


def _scenario(tmp_path, topology: str, extra: str = "") -> object:
    path = tmp_path / "s.yaml"
    path.write_text(f"name: t\nduration_s: 2\ntopology:\n{textwrap.indent(topology, '  ')}{extra}")
    return path


def _error(path) -> str:
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    return str(err.value)


def test_an_unknown_name_is_refused_with_the_known_ones(tmp_path):
    path = _scenario(tmp_path, "name: ring\nclusters: 2\n")
    message = _error(path)
    assert message.startswith(f"{path}:4: topology.name: unknown topology 'ring'"), message
    assert all(name in message for name in topos), message


@pytest.mark.parametrize(("topology", "line", "key", "expect"), [
    ("name: star\nlink_delay_ms: -1\n", 5, "topology.link_delay_ms", "greater than or equal to 0"),
    ("name: star\nclusters: 0\n", 5, "topology.clusters", "greater than or equal to 1"),
    ("name: farm\nlayout: ring\n", 5, "topology.layout", "'compact' or 'tower'"),
    ("name: paper\nlayout: tower\n", 5, "topology.layout", "not an option of topology paper (its options: clusters"),
    ("name: star\nclusters: 2\nspeed: 3\n", 6, "topology.speed", "not an option of topology star"),
    ("name: star\noptions: 3\n", 5, "topology.options", "not an option of topology star"),
])
def test_a_bad_option_names_file_line_and_key(tmp_path, topology, line, key, expect):
    path = _scenario(tmp_path, topology)
    message = _error(path)
    assert message.startswith(f"{path}:{line}: {key}: "), message
    assert expect in message, message


def test_each_topology_gets_its_own_defaults(tmp_path):
    farm = load_scenario(_scenario(tmp_path, "name: farm\n")).topology
    assert farm.params() == {"clusters": 5, "turbines": 10, "layout": "compact", "onshore_units": 0}
    paper = load_scenario(_scenario(tmp_path, "name: paper\nclusters: 1\n")).topology
    assert paper.params() == {"clusters": 1, "turbines": 2}


def test_the_star_survives_any_single_link_and_carries_its_delay():
    desc = describe(topos["star"](clusters=3, turbines=2, link_delay_ms=0.5))
    assert [link["delay_s"] for link in desc["links"]] == [0.0005] * 7  # h1-h2 and two per cluster
    graph = nx.Graph([(lk["a"], lk["b"]) for lk in desc["links"]]
                     + [(name, h["switch"]) for name, h in desc["hosts"].items()])
    turbines = [n for n, h in desc["hosts"].items() if h["role"] == "turbine"]
    assert len(turbines) == 6
    for link in desc["links"]:
        cut = graph.copy()
        cut.remove_edge(link["a"], link["b"])
        assert all(nx.has_path(cut, sdc, wt) for sdc in ("sdc1", "sdc2") for wt in turbines), link
    assert all(lk["delay_s"] == 0.0 for lk in describe(topos["star"](clusters=2))["links"])


def test_a_custom_file_is_taken_relative_to_the_scenario(tmp_path):
    (tmp_path / "topos").mkdir()
    (tmp_path / "topos" / "line.py").write_text(CUSTOM)
    sc = load_scenario(_scenario(tmp_path, "name: line\ncustom: topos/line.py\nclusters: 1\nturbines: 3\n",
                                 "timeline:\n  - {t: 1.0, do: visc_on, wt: wt1_3}\n"))
    desc = describe(sc.topology.topo_class()(**sc.topology.params()))
    assert desc["links"] == [{"a": "x1", "a_port": 1, "b": "x2", "b_port": 1, "delay_s": 0.003}]
    cfg = configs.plant_config(sc, desc, str(tmp_path), {})
    assert {t.name: t.plant_index for t in cfg.turbines} == {"wt1_1": 7, "wt1_2": 8, "wt1_3": 9}
    message = _error(_scenario(tmp_path, "name: line\ncustom: topos/line.py\n",
                               "timeline:\n  - {t: 1.0, do: visc_on, wt: wt1_3}\n"))
    assert "topology.clusters" not in message and "turbine 'wt1_3' is not in topology line" in message, message
    message = _error(_scenario(tmp_path, "name: line\ncustom: topos/line.py\nlayout: tower\n"))
    assert "topology.layout: not an option of topology line (its options: clusters (5), turbines (2))" in message


@pytest.mark.parametrize(("text", "expect"), [
    (None, "No such file"),
    ("x = 1\n", "defines no topology: it must export topos"),
    ("topos = {'a': int}\n", "is not a Mininet Topo class"),
    ("raise RuntimeError('broken')\n", "failed: RuntimeError: broken"),
    (CUSTOM.replace('{"line": LineTopo}', '{"farm": LineTopo}'), "farm would hide the built-in topology"),
])
def test_a_bad_custom_file_is_named(tmp_path, text, expect):
    if text is not None:
        (tmp_path / "mine.py").write_text(text)
    path = _scenario(tmp_path, "name: farm\ncustom: mine.py\n")
    message = _error(path)
    assert message.startswith(f"{path}:5: topology.custom: custom topology file {tmp_path / 'mine.py'}"), message
    assert expect in message, message


def test_plant_index_places_each_turbine_in_its_cluster_of_the_plant_model():
    """The topology's plant_index against the electrical model's own grouping (plant/network.py:
    converter k of the N-turbine farm is in cluster k*C // N): wt<c>_<n> must land in cluster c."""
    p = PlantParams()
    n_farm = 50
    desc = describe(topos["farm"](onshore_units=1))
    for name, host in desc["hosts"].items():
        if host["role"] != "turbine":
            continue
        k = host["plant_index"]
        if host["cluster"] <= p.n_clusters:
            assert k < n_farm and k * p.n_clusters // n_farm == host["cluster"] - 1, name
        else:  # the onshore unit: the first converter after the farm's
            assert k == n_farm + host["number"] - 1, name
    assert len({h["plant_index"] for h in desc["hosts"].values() if h["role"] == "turbine"}) == 51


def test_the_run_record_reads_the_plant_index_the_run_was_given(tmp_path):
    (tmp_path / "plant_config.json").write_text(json.dumps({"turbines": [
        {"name": "wt3_1", "plant_index": 20}, {"name": "wt1_1", "plant_index": 0}]}))
    assert plant_indices(tmp_path) == {"wt3_1": 20, "wt1_1": 0}
    (tmp_path / "plant_config.json").write_text(json.dumps({"turbines": [{"name": "wt3_1"}]}))
    with pytest.raises(ValueError, match="no plant_index for wt3_1"):
        plant_indices(tmp_path)


@pytest.mark.parametrize(("delay", "seconds"), [(None, 0.0), ("2ms", 2e-3), ("500us", 5e-4), ("1s", 1.0),
                                                ("1.5ms", 1.5e-3), (250, 2.5e-4), ("40", 4e-5)])
def test_a_mininet_delay_in_seconds(delay, seconds):
    assert delay_seconds(delay) == pytest.approx(seconds, rel=1e-12)


def test_the_plant_takes_the_converter_the_description_gives():
    from plant.service.model import endpoint_indices, farm_index
    from sdvisc.config import PlantConfig

    def config(*turbines):
        return PlantConfig(step_s=0.00067, out_dir="unused", duration_s=1.0, model="full", turbines=[
            {"name": name, "wid": 100 + k + 1, "ip": f"10.0.1.{k + 1}", "plant_index": index}
            for k, (name, index) in enumerate(turbines)])

    given = endpoint_indices(config(("wt1_1", 7), ("wt1_2", None)))
    assert given == {"wt1_1": 7}
    assert farm_index("wt1_1", 50, given=given.get("wt1_1")) == 7
    assert farm_index("wt1_2", 50, given=given.get("wt1_2")) == 1  # an endpoint written without one: the rule
    with pytest.raises(ValueError, match="wt1_1 and wt1_2 are both converter 7"):
        endpoint_indices(config(("wt1_1", 7), ("wt1_2", 7)))
    with pytest.raises(ValueError, match="wt1_1 has no converter in the 50-turbine farm model"):
        farm_index("wt1_1", 50, given=50)


def test_a_custom_topology_that_fails_to_build_is_named(tmp_path):
    (tmp_path / "broken.py").write_text(CUSTOM.replace('x1, x2 = self.add_switch', 'raise KeyError("no x3")\n        x1, x2 = self.add_switch'))
    path = _scenario(tmp_path, "name: line\ncustom: broken.py\n")
    message = _error(path)
    assert message.startswith(f"{path}:3: topology: topology line (clusters=5, turbines=2) cannot be built: "
                              "KeyError: 'no x3'"), message


def test_a_plain_mininet_topo_gets_its_options_from_build(tmp_path):
    (tmp_path / "plain.py").write_text(textwrap.dedent('''
        from mininet.topo import Topo

        class Pair(Topo):
            def build(self, hosts: int = 2, label="x"):
                pass

        topos = {"pair": Pair}
    '''))
    sc_path = _scenario(tmp_path, "name: pair\ncustom: plain.py\nhosts: many\n")
    message = _error(sc_path)
    assert f"{sc_path}:6: topology.hosts: Input should be a valid integer" in message, message


def test_the_options_are_in_the_dump_and_read_back(tmp_path):
    """What the calibration cache keys on (the scenario's dump) holds the topology's options, and a
    dump validates back to the same topology."""
    from scenarios.calibration_cache import shape_of
    from scenarios.schema import TopologySpec

    one = load_scenario(_scenario(tmp_path, "name: star\nclusters: 2\n"))
    two = load_scenario(_scenario(tmp_path, "name: star\nclusters: 3\n"))
    assert shape_of(one)["topology"] != shape_of(two)["topology"]
    dump = two.topology.model_dump(mode="json")
    assert dump["options"] == {"clusters": 3, "turbines": 2, "link_delay_ms": 0.0}
    assert TopologySpec.model_validate(dump).params() == two.topology.params()


def test_mininet_topo_arguments_go_through_the_options_model():
    """``mn --custom topologies/__init__.py --topo farm,2,3`` and ``--topo star,link_delay_ms=0.5``
    (Mininet's own parser, mininet.util.buildTopo) get the same checks as a scenario."""
    from mininet.util import buildTopo
    from pydantic import ValidationError

    farm = describe(buildTopo(topos, "farm,2,3"))
    assert sorted(n for n, h in farm["hosts"].items() if h["role"] == "turbine")[-1] == "wt2_3"
    star = describe(buildTopo(topos, "star,clusters=2,link_delay_ms=0.5"))
    assert {lk["delay_s"] for lk in star["links"]} == {0.0005}
    with pytest.raises(ValidationError, match="layout"):
        buildTopo(topos, "farm,layout=ring")
    with pytest.raises(TypeError, match="at most 4 options"):
        buildTopo(topos, "farm,1,2,compact,0,9")
