"""Every process's configuration comes from one schema (sdvisc/config.py): what the runner
derives from each shipped scenario validates, round-trips through its file, and bad files are
refused with the file and key named (pure, no network)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from plant.card.core import GtnetCardConfig
from scenarios import configs
from scenarios.external import ExternalDevices
from scenarios.loader import load_scenario
from sdvisc.config import (
    AppConfig,
    ConfigError,
    OwfccConfig,
    PlantConfig,
    SdcConfig,
    load_config,
    parse_config,
    write_config,
)
from topologies import topos
from topologies.base import describe

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = sorted((ROOT / "scenarios").glob("*.yaml")) + sorted((ROOT / "scenarios" / "paper").glob("*.yaml"))


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_every_shipped_scenario_gives_valid_process_configs(path, tmp_path):
    sc = load_scenario(path)
    topo = topos[sc.topology.name](**sc.topology.params())
    desc = describe(topo)
    out = str(tmp_path)
    if sc.plant.model == "external":  # the card emulator's configuration instead of the plant's
        devices = ExternalDevices(sc)
        desc = devices.detach(topo, desc)
        card = GtnetCardConfig(**devices.peer_config(desc["hosts"]["sdc1"]["ip"], out, {}, sc.duration_s))
        assert [(t.name, t.port) for t in card.turbines] == list(sc.plant.peer.turbines.items())
        assert card.header == configs.framing_header(sc)
    pids = {n: None for n, h in desc["hosts"].items() if h["role"] == "turbine"}
    made = [(AppConfig, configs.app_config(sc, desc, out)), (OwfccConfig, configs.owfcc_config(sc, out))]
    made += [(SdcConfig, configs.sdc_config(sc, desc, out, i, role)) for _, i, role in configs.sdcs(sc)]
    if sc.plant.model != "external":
        made.insert(2, (PlantConfig, configs.plant_config(sc, desc, out, pids)))
    for model, cfg in made:
        back = load_config(model, write_config(cfg, tmp_path / f"{model.__name__}.json"))
        assert back == cfg
        assert cfg.header == configs.framing_header(sc)  # one framing for every process of a run
    if sc.plant.model == "external":
        return
    plant = made[2][1]
    assert plant.step_s == sc.step_s and plant.report_loss_after_s == sc.sdn.dr_hold_s
    assert made[0][1].turbine_fallback_s == sc.plant.remote_loss_fallback_s
    assert sc.sdc.gather_steps == made[3][1].gather_steps
    if path.stem == "f7_weak_grid_visc":  # SCR 7.14 -> 1.58 at 1 s: factorised before t = 0
        assert plant.prepare_scr == [1.58]
    elif not any(e.do == "scr" for e in sc.timeline):
        assert plant.prepare_scr == []


def test_a_bad_config_file_names_every_problem(tmp_path):
    path = tmp_path / "sdc.json"
    path.write_text(json.dumps({"step_s": -1, "out_dir": ".", "role": "boss", "colour": "red"}))
    with pytest.raises(ConfigError) as err:
        load_config(SdcConfig, path)
    text = str(err.value)
    assert f"{path}: step_s:" in text and f"{path}: role:" in text and f"{path}: colour: unknown key" in text


def test_non_finite_numbers_are_refused():
    with pytest.raises(ConfigError):
        parse_config(SdcConfig, {"step_s": float("nan"), "out_dir": "."})


def test_grid_batteries_and_p_star_reach_the_plant_model(tmp_path):
    """plant.grid / plant.batteries / plant.p_star -> PlantConfig -> plant.service.model.build_model (no network)."""
    import numpy as np

    from plant.service.model import build_model

    path = tmp_path / "s.yaml"
    path.write_text("name: t\nduration_s: 3\ntopology: {name: farm, clusters: 5, turbines: 10}\n"
                    "plant:\n  model: full\n  grid: {h: 4.0, s_mva: 1000, d: 2}\n"
                    "  batteries: {turbines: [wt3_1, wt3_2], soc_init: 0.7}\n  p_star: {wt3_1: 0.0, wt3_2: 0.25}\n")
    sc = load_scenario(path)
    desc = describe(topos[sc.topology.name](**sc.topology.params()))
    pids = {n: None for n, h in desc["hosts"].items() if h["role"] == "turbine"}
    cfg = load_config(PlantConfig, write_config(configs.plant_config(sc, desc, str(tmp_path), pids),
                                                tmp_path / "plant.json"))
    assert cfg.grid.given() == {"h_grid": 4.0, "s_grid_mva": 1000.0, "d_grid": 2.0}
    assert cfg.batteries == ["wt3_1", "wt3_2"] and cfg.battery_soc_init == 0.7
    assert cfg.p_star == {"wt3_1": 0.0, "wt3_2": 0.25}
    plant, indices = build_model(cfg, ["wt3_1", "wt1_1"])
    assert indices == [20, 0]
    g = plant.params.grid
    assert (g.h_grid, g.s_grid_mva, g.d_grid, g.r_gov) == (4.0, 1000.0, 2.0, 0.05)  # r_gov not given: default
    assert list(np.nonzero(plant.tb.battery)[0]) == [20, 21]
    assert plant.params.battery.soc_init == 0.7 and np.allclose(plant.tb.batt.soc, 0.7)
    out = plant.outputs()
    p_me = out["p_wt"] + plant.params.turbine.rf * out["i_wt"] ** 2  # the terminal's P + the filter's loss
    assert abs(p_me[20]) < 1e-6 and p_me[21] == pytest.approx(0.25, abs=1e-6)
    assert out["p_wt"][0] > 0.9  # the others on the MPPT curve
    assert np.allclose(out["p_batt"], 0.0, atol=1e-9)  # the packs float on the DC link at t = 0
    plant.set_mode([20, 21], "hd_visc")  # the battery backs a ViSC's DC link (a grid-following MSC holds it)
    plant.load_step(100.0)
    for _ in range(300):
        plant.step()
    out = plant.outputs()
    assert out["f_pcc_hz"] < 50.0  # a finite-inertia source: the frequency moves
    assert out["soc"][20] < 0.7 and out["soc"][0] == 0.7  # the battery gave energy, the others none
    # a minimal plant refuses them (the schema does too, at the file)
    with pytest.raises(ValueError, match="full plant model"):
        build_model(cfg.model_copy(update={"model": "minimal"}), ["wt3_1"])


def test_recorder_writes_battery_columns_and_keeps_extremes(tmp_path):
    from plant.cases import visc_plant
    from plant.service.recorder import Recorder

    plant = visc_plant(4, battery=True, h_grid=5.0, s_grid_mva=1000.0)
    rec = Recorder(tmp_path / "ts.csv", [], every=5, batteries={"wt3_1": 20})
    plant.load_step(100.0)
    for k in range(1, 301):
        plant.step()
        rec.maybe_record(k, plant)
    rec.close()
    lines = (tmp_path / "ts.csv").read_text().splitlines()
    assert lines[0] == "t,v_pcc,f_pcc_hz,wt3_1.soc,wt3_1.p_batt" and len(lines) == 61
    ext = rec.extremes()
    assert ext["f_pcc_hz"]["min"] < 50.0 < ext["f_pcc_hz"]["max"] + 0.1
    soc_min, p_max = ext["batteries"]["wt3_1"]["soc_min"], ext["batteries"]["wt3_1"]["p_batt_max"]
    assert soc_min < 0.5 and p_max > 0.0
    assert float(lines[-1].split(",")[3]) == pytest.approx(soc_min, abs=1e-8)
