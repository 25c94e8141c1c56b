"""SDN managers and path policies (issue 41): the old booleans and the ``sdn.managers`` list give
the same decisions; a selector limits a manager to its turbines; every route, detours and second
legs included, is the scenario's path policy's; the ``delay`` policy takes the least-delay path and
is the ``hops`` policy when no delay is known."""

from __future__ import annotations

import itertools

import pytest

from scenarios.loader import ScenarioError, load_scenario
from sdn_app import flows as fl
from sdn_app.logic import Controller
from sdn_app.managers import MANAGERS
from sdn_app.path_policies import PATH_POLICIES
from sdn_app.paths import choose_path, path_links
from sdvisc.config import AppConfig, SdnOptions
from tests.unit.test_sdn_duplication import visc_on
from tests.unit.test_sdn_logic import make_config
from tests.unit.test_sdn_resilience import HOLD, ak
from topologies import topos
from topologies.base import describe

FARM = {"clusters": 5, "turbines": 2, "layout": "compact"}
LEGACY = {"fast_failover": "fast_failover", "duplicate_paths": "duplication",
          "reroute_on_port_status": "port_status_reroute"}


def farm_controller(**options) -> Controller:
    desc = describe(topos["farm"](**FARM))
    return Controller(AppConfig.model_validate({"topology": desc, "backup_sdc": "sdc2", **options}), 0.0)


def decisions(ctl: Controller, wt: str) -> list:
    """What a ViSC request for ``wt`` and then the failure of its path's first switch-to-switch
    link make the app send, and the events they record."""
    actions = visc_on(ctl, wt, now=1.0)
    path = ctl.paths[wt].path
    link = path_links(path)[1]
    switch, port = min((sw, p) for (sw, p), key in ctl.port_links.items() if key == link and sw in ctl.dpids)
    actions += ctl.port_status(ctl.dpids[switch], port, up=False, now=1.5)
    return actions + ctl.take_events()


@pytest.mark.parametrize("boolean", sorted(LEGACY))
def test_an_old_boolean_and_its_manager_entry_decide_the_same(boolean):
    by_boolean = farm_controller(**{boolean: True})
    by_list = farm_controller(managers=[{"name": LEGACY[boolean]}])
    same = decisions(by_boolean, "wt1_2")
    assert same == decisions(by_list, "wt1_2")
    assert same != decisions(farm_controller(), "wt1_2")  # the manager changed something


def test_the_defaults_are_the_guard_dynamic_routing_and_the_mirror():
    assert set(SdnOptions().manager_selection()) == {"ingress_guard", "dynamic_routing", "mirror"}
    everything = SdnOptions(fast_failover=True, duplicate_paths=True, reroute_on_port_status=True)
    assert set(everything.manager_selection()) == set(MANAGERS)  # every name the booleans give is a manager


def test_a_selector_limits_a_manager_to_its_turbines():
    ctl = farm_controller(managers=[{"name": "duplication", "turbines": ["wt1_2"]}])
    visc_on(ctl, "wt1_2", now=1.0)
    visc_on(ctl, "wt3_2", now=1.1)
    assert ctl.paths["wt1_2"].second_leg is not None
    assert ctl.paths["wt3_2"].second_leg is None
    assert ctl.counters["duplicated"] == 1 and ctl.counters["not_duplicated"] == 0  # not selected, not "impossible"


def test_dr_of_a_turbine_without_dynamic_routing_is_logged_only():
    ctl = Controller(make_config(backup_sdc=None, managers=[{"name": "dynamic_routing", "turbines": ["wt1_2"]}]),
                     now=0.0)
    visc_on(ctl, "wt1_1", now=1.0)
    path = ctl.paths["wt1_1"].path
    ak(ctl, 1, 1, 0.0, 1.5)
    ak(ctl, 2, 0, 0.012, 1.52)
    actions = ak(ctl, 3, 0, 0.041, 1.508 + HOLD + 0.001)
    assert not [a for a in actions if isinstance(a, fl.FlowAdd)]
    assert ctl.paths["wt1_1"].path == path
    assert [e["type"] for e in ctl.take_events() if e["type"] in ("dr", "dr_not_acted")] == ["dr_not_acted"]


def test_the_ingress_guard_can_be_switched_off():
    def upstream_on_ingress(ctl):
        actions = visc_on(ctl, "wt1_1", now=1.0)
        wt_ip = ctl.config.topology.hosts["wt1_1"].ip
        ingress = ctl.dpids[ctl.paths["wt1_1"].path[-3]]  # the OpenFlow switch before the L2 switch l2
        return [a for a in actions if isinstance(a, fl.FlowAdd) and a.dpid == ingress and a.match.get("ipv4_src") == wt_ip]

    guarded = upstream_on_ingress(Controller(make_config(backup_sdc=None), now=0.0))
    open_ = upstream_on_ingress(Controller(make_config(backup_sdc=None,
                                                       managers=[{"name": "ingress_guard", "turbines": []}]), now=0.0))
    assert guarded and all("eth_src" in f.match and "in_port" in f.match for f in guarded)
    assert open_ and not any("eth_src" in f.match for f in open_)


@pytest.mark.parametrize(("managers", "says"), [([{"name": "bogus"}], "unknown manager"),
                                                ([{"name": "mirror", "turbines": ["wt9_9"]}], "not turbine")])
def test_an_unknown_manager_or_turbine_is_refused_at_start(managers, says):
    with pytest.raises(ValueError, match=says):
        Controller(make_config(managers=managers), now=0.0)


def test_a_scenario_naming_an_unknown_manager_policy_or_turbine_is_refused_with_its_line(tmp_path):
    cases = {"managers: [{name: duplicaton}]": "unknown ['duplicaton']",
             "path_policy: fastest": "unknown 'fastest'",
             "managers: [{name: duplication, turbines: [wt9_1]}]": "sdn.managers.0.turbines.0"}
    for line, says in cases.items():
        path = tmp_path / "s.yaml"
        path.write_text(f"name: s\ntopology: {{name: paper}}\nduration_s: 1.0\nsdn:\n  {line}\n")
        with pytest.raises(ScenarioError, match=r"s\.yaml:[45]:") as err:
            load_scenario(path)
        assert says in str(err.value)


def test_a_listed_manager_twice_is_refused():
    with pytest.raises(ValueError, match="more than once"):
        SdnOptions(managers=[{"name": "mirror"}, {"name": "mirror", "turbines": ["wt1_1"]}])


# ------------------------------------------------------------------ path policies

def paper_with_delay(delays: dict[frozenset, float], **options) -> Controller:
    desc = describe(topos["paper"](clusters=1, turbines=2))
    for link in desc["links"]:
        link["delay_s"] = delays.get(frozenset((link["a"], link["b"])), 0.0)
    return Controller(AppConfig.model_validate({"topology": desc, "backup_sdc": None, **options}), 0.0)


def test_the_delay_policy_takes_the_path_of_least_delay():
    slow = {frozenset(("s1", "s3")): 0.005}
    assert paper_with_delay(slow).state.path_to("sdc1", "wt1_1") == ["sdc1", "s1", "s3", "l2", "wt1_1"]
    by_delay = paper_with_delay(slow, path_policy="delay")
    assert by_delay.state.path_to("sdc1", "wt1_1") == ["sdc1", "s1", "s4", "l2", "wt1_1"]
    # a longer way of less delay wins; of equal delay, the fewer hops
    longer = paper_with_delay({**slow, frozenset(("s1", "s4")): 0.005}, path_policy="delay")
    assert longer.state.path_to("sdc1", "wt1_1") == ["sdc1", "s1", "s2", "s3", "l2", "wt1_1"]


@pytest.mark.parametrize(("topo", "params"), [("paper", {"clusters": 2, "turbines": 2}), ("farm", FARM)])
def test_the_delay_policy_without_delays_is_the_hops_policy(topo, params):
    ctl = Controller(AppConfig.model_validate({"topology": describe(topos[topo](**params))}), 0.0)
    nodes = sorted(ctl.graph.nodes)
    down = {frozenset(("s1", "s3"))}
    for src, dst in itertools.combinations(nodes, 2):
        assert choose_path(ctl.graph, src, dst, down=down, policy="delay") == choose_path(ctl.graph, src, dst,
                                                                                           down=down)


def test_every_route_is_the_policys(monkeypatch):
    """Detours (fast failover), second legs (duplication) and the mirror's way are all chosen by the
    scenario's policy: a policy that records its calls sees them all."""
    asked = []

    def recording(view, src, dst):
        asked.append((src, dst))
        return PATH_POLICIES["hops"](view, src, dst)

    monkeypatch.setitem(PATH_POLICIES, "recording", recording)
    ctl = farm_controller(fast_failover=True, duplicate_paths=True, path_policy="recording")
    visc_on(ctl, "wt1_2", now=1.0)
    active = ctl.paths["wt1_2"]
    leg = active.second_leg
    assert ("sdc1", "wt1_2") in asked  # the path
    assert (leg[0], leg[-1]) in asked  # the second leg
    assert (active.path[1], "sdc2") in asked  # the mirror's way
    protected = [x for x, nxt in zip(active.path[1:], active.path[2:]) if x in ctl.dpids and nxt in ctl.dpids]
    assert protected and all((x, "wt1_2") in asked for x in protected)  # each one's detour
    assert active.groups


def test_a_new_manager_is_its_class_and_a_registry_line(monkeypatch):
    """Nothing else lists the managers: one registered here is enabled by ``sdn.managers`` and its
    flows hook runs for the turbines it selects, after the built-in ones."""
    from sdn_app.managers.base import Manager

    class CountToController(Manager):  # e.g. a copy of every upstream packet to the controller
        def flows(self, routing, active, flows):
            return flows + [fl.FlowAdd(1, 5, {"ipv4_src": routing.state.endpoint(active.wt)[0]},
                                       (fl.Output(fl.TO_CONTROLLER),), active.cookie)]

    monkeypatch.setitem(MANAGERS, "count_to_controller", CountToController)
    ctl = Controller(make_config(backup_sdc=None, managers=[{"name": "count_to_controller", "turbines": ["wt1_2"]}]),
                     now=0.0)
    mine = lambda actions: [a for a in actions if isinstance(a, fl.FlowAdd) and a.priority == 5]  # noqa: E731
    assert mine(visc_on(ctl, "wt1_1", now=1.0)) == []
    (added,) = mine(visc_on(ctl, "wt1_2", now=1.1))
    assert added.match == {"ipv4_src": ctl.config.topology.hosts["wt1_2"].ip}


def test_the_published_state_names_the_managers_and_the_policy():
    ctl = Controller(make_config(backup_sdc=None, duplicate_paths=True, path_policy="delay",
                                 managers=[{"name": "fast_failover", "turbines": ["wt1_2"]}]), now=0.0)
    snap = ctl.snapshot()
    assert snap["managers"] == {"ingress_guard": None, "dynamic_routing": None, "mirror": None, "duplication": None,
                                "fast_failover": ["wt1_2"]}
    assert snap["path_policy"] == "delay"
