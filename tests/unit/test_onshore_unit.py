"""The onshore aggregated SDViSC as a network endpoint (issue 28 item 1, the cyber half), without
switches: ``topology.onshore_units`` puts host wt6_1 on the substation switch sub1, the plant service
builds the comparison arrangement's plant with it as converter 50, bad values name file, line and key,
and a scenario without the key is what it was."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from plant.cases import COMPARISON_UNIT, comparison_visc_plant
from plant.service.model import build_model, farm_index
from scenarios import configs
from scenarios.loader import ScenarioError, load_scenario
from sdvisc import wire
from sdvisc.vocabulary import ONSHORE_CLUSTER, onshore_host
from topologies import topos
from topologies.base import describe

FARM = "name: t\nduration_s: 3\ntopology: {name: farm, clusters: 5, turbines: 10, layout: compact%s}\n"
FULL = "plant: {model: full, p_star: {wt6_1: 0.0}}\n"


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "s.yaml"
    path.write_text(text)
    return path


def _desc(sc) -> dict:
    return describe(topos[sc.topology.name](**sc.topology.params()))


def test_the_onshore_unit_is_wt6_1_and_converter_50():
    assert onshore_host(1) == "wt6_1" and ONSHORE_CLUSTER == 6
    assert wire.turbine_id(*wire.parse_turbine("wt6_1")) == 601 and wire.turbine_name(601) == "wt6_1"
    assert farm_index("wt6_1", 50, onshore_units=1) == COMPARISON_UNIT == 50
    assert farm_index("wt6_2", 50, onshore_units=2) == 51
    assert farm_index("wt5_10", 50) == 49  # the farm's last turbine, unchanged
    for name, units in (("wt6_1", 0), ("wt6_2", 1)):  # no such unit in the plant
        with pytest.raises(ValueError, match=f"{name} has no converter"):
            farm_index(name, 50, onshore_units=units)
    with pytest.raises(ValueError):
        onshore_host(0)


def test_the_host_hangs_on_sub1_and_nothing_else_changes(tmp_path):
    plain = load_scenario(_write(tmp_path, FARM % "" + "plant: {model: full}\n"))
    with_unit = load_scenario(_write(tmp_path, FARM % ", onshore_units: 1" + FULL))
    assert plain.topology.option("onshore_units") == plain.topology.params()["onshore_units"] == 0
    assert with_unit.topology.params()["onshore_units"] == 1
    d0, d1 = _desc(plain), _desc(with_unit)
    host = d1["hosts"].pop("wt6_1")
    assert host["switch"] == "sub1" and host["role"] == "turbine" and (host["cluster"], host["number"]) == (6, 1)
    assert host["ip"] == "10.0.6.1" and host["mac"] == "02:00:00:00:06:01"
    assert d1 == d0  # every other host, port and link as without the key
    tower = load_scenario(_write(tmp_path, FARM.replace("compact", "tower") % ", onshore_units: 2" + FULL))
    assert {n: h["switch"] for n, h in _desc(tower)["hosts"].items() if n.startswith("wt6_")} == \
        {"wt6_1": "sub1", "wt6_2": "sub1"}


def test_the_plant_service_builds_the_comparison_arrangement(tmp_path):
    sc = load_scenario(_write(tmp_path, FARM % ", onshore_units: 1" + FULL
                              + "timeline:\n  - {t: 0.2, do: visc_on, wt: wt6_1}\n"))
    desc = _desc(sc)
    cfg = configs.plant_config(sc, desc, str(tmp_path), {n: None for n, h in desc["hosts"].items()
                                                         if h["role"] == "turbine"})
    assert cfg.onshore_units == 1 and "wt6_1" in [t.name for t in cfg.turbines]
    assert next(t.wid for t in cfg.turbines if t.name == "wt6_1") == 601
    assert configs.sdc_config(sc, desc, str(tmp_path), 1, "primary").capacity == 51
    plant, indices = build_model(cfg, ["wt6_1", "wt3_1"])
    assert indices == [COMPARISON_UNIT, 20] and plant.n == 51
    assert plant.net.rating_mva[COMPARISON_UNIT] == 40.0
    ref = comparison_visc_plant(activate=False)  # the offline F3–F7's case before its SDViSC is switched on
    ours, theirs = plant.outputs(), ref.outputs()
    assert ours["v_pcc"] == pytest.approx(theirs["v_pcc"], abs=1e-9)
    assert np.allclose(ours["p_wt"], theirs["p_wt"], atol=1e-9) and np.allclose(ours["q_wt"], theirs["q_wt"], atol=1e-9)
    plain = cfg.model_copy(update={"onshore_units": 0})
    with pytest.raises(ValueError, match="wt6_1 has no converter"):
        build_model(plain, ["wt6_1"])
    with pytest.raises(ValueError, match="full plant model"):
        build_model(cfg.model_copy(update={"model": "minimal", "p_star": {}}), ["wt6_1"])


@pytest.mark.parametrize(
    ("text", "line", "key", "expect"),
    [
        (FARM % ", onshore_units: -1" + FULL, 3, "topology.onshore_units", "greater than or equal to 0"),
        (FARM % ", onshore_units: 11" + FULL, 3, "topology.onshore_units", "less than or equal to 10"),
        (FARM % ", onshore_units: one" + FULL, 3, "topology.onshore_units", "valid integer"),
        (FARM % ", onshore_units: 1.5" + FULL, 3, "topology.onshore_units", "integer"),
        ("name: t\nduration_s: 3\ntopology:\n  name: paper\n  onshore_units: 1\nplant: {model: full}\n", 5,
         "topology.onshore_units", "not an option of topology paper"),
        ("name: t\nduration_s: 3\ntopology:\n  name: farm\n  clusters: 6\n  onshore_units: 1\nplant: {model: full}\n",
         6, "topology.onshore_units", "at most 5 clusters"),
        ("name: t\nduration_s: 3\nplant: {model: minimal}\ntopology:\n  name: farm\n  onshore_units: 1\n", 6,
         "topology.onshore_units", "needs plant.model: full or emt, not minimal"),
        (FARM % "" + "plant: {model: full}\ntimeline:\n  - {t: 1.0, do: visc_on, wt: wt6_1}\n", 6, "timeline.0.wt",
         "turbine 'wt6_1' is not in topology farm"),
        (FARM % ", onshore_units: 1" + "plant: {model: full, p_star: {wt6_2: 0.0}}\n", 4, "plant.p_star.wt6_2",
         "not in topology"),
    ],
)
def test_bad_onshore_values_name_file_line_and_key(tmp_path, text, line, key, expect):
    path = _write(tmp_path, text)
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    message = str(err.value)
    assert message.startswith(f"{path}:{line}: {key}:"), message
    assert expect in message, message


def test_the_paper_files_run_the_onshore_unit_and_keep_the_cluster3_variant():
    root = Path(__file__).resolve().parents[2] / "scenarios" / "paper"
    for stem in ("f3_voltage_step", "f4_inertia_50mw", "f5_inertia_100mw_battery", "f6_slg_fault_current",
                 "f7_weak_grid_visc"):
        sc = load_scenario(root / f"{stem}.yaml")
        assert sc.topology.option("onshore_units") == 1 and sc.plant.model == "full"
        assert [e.wt for e in sc.timeline if e.do == "visc_on"] == ["wt6_1"] and sc.plant.p_star == {"wt6_1": 0.0}
        old = load_scenario(root / f"{stem}_cluster3.yaml")
        assert old.topology.option("onshore_units") == 0 and old.name == f"{stem}_cluster3"
        assert [e.wt for e in old.timeline if e.do == "visc_on"] == ["wt3_1", "wt3_2", "wt3_3", "wt3_4"]
