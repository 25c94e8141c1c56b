"""Every process's configuration comes from one schema (sdvisc/config.py): what the runner
derives from each shipped scenario validates, round-trips through its file, and bad files are
refused with the file and key named (pure, no network)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from scenarios import configs
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
    desc = describe(topos[sc.topology.name](**sc.topology.params()))
    out = str(tmp_path)
    pids = {n: None for n, h in desc["hosts"].items() if h["role"] == "turbine"}
    made = [(AppConfig, configs.app_config(sc, desc, out)), (OwfccConfig, configs.owfcc_config(sc, out)),
            (PlantConfig, configs.plant_config(sc, desc, out, pids))]
    made += [(SdcConfig, configs.sdc_config(sc, desc, out, i, role)) for _, i, role in configs.sdcs(sc)]
    for model, cfg in made:
        back = load_config(model, write_config(cfg, tmp_path / f"{model.__name__}.json"))
        assert back == cfg
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
