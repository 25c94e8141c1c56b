"""One configuration source (issue 31): every option of every process configuration
(sdvisc/config.py) is set from a scenario file — YAML → scenarios.loader → scenarios.configs (or
scenarios.impairments) → the process's model, read back from its JSON file — or is listed here as
derived by the run (or as an option of a deployed service alone, which a run leaves at its
default), with the reason; and no option is defined twice with different bounds or
defaults (the ``model_fields`` of the scenario's sections and of the process configurations).
Pure: no network."""

from __future__ import annotations

import copy
import typing
from pathlib import Path

import pytest
import yaml
from pydantic import BaseModel, Field
from pydantic.fields import FieldInfo

from plant.params import BatteryParams
from scenarios import configs
from scenarios.impairments import Impairments
from scenarios.loader import load_scenario
from scenarios.schema import BatterySpec, PlantSpec, Scenario, TopologySpec
from sdvisc.config import (
    BATTERY_SOC_LIMITS,
    AppConfig,
    ImpairNodeConfig,
    ManagerChoice,
    OwfccConfig,
    PlantConfig,
    SdcConfig,
    TopologyInfo,
    TurbineEndpoint,
    load_config,
    write_config,
)
from topologies import topos
from topologies.base import describe
from topologies.options import options_of

PROCESS_CONFIGS = (AppConfig, SdcConfig, PlantConfig, OwfccConfig, ImpairNodeConfig)
DATA_MODELS = (TopologyInfo, TurbineEndpoint,  # the built network as the processes see it, not options
               ManagerChoice)  # an entry of sdn.managers: the list is the option

RUN_DERIVED = {  # (process config, option; "*": every config): why no scenario key sets it
    ("*", "time_scale"): "the run's clock: the scenario's time_scale as the runner resolves it (auto: measured "
                         "before t = 0, scenarios.calibrate), handed to scenarios.configs as clock=",
    ("*", "clock_epoch"): "the run's clock: the wall time at which the runner starts it",
    ("*", "controller_vip"): "a testbed constant, sdvisc.config.CONTROLLER_VIP",
    ("*", "header"): "the wire format: a run always sends the GTNET header (tests turn it off)",
    ("*", "out_dir"): "the run's output directory (sdvisc run --out)",
    ("*", "realtime_priority"): "SCHED_FIFO wherever allowed; tests turn it off",
    ("AppConfig", "topology"): "the built topology: topologies.base.describe of the scenario's topology",
    ("AppConfig", "controller_vmac"): "a testbed constant, sdvisc.config.CONTROLLER_VMAC",
    ("AppConfig", "owfcc"): "a host name every topology has",
    ("AppConfig", "primary_sdc"): "a host name every topology has (the backup: sdc.backup)",
    ("AppConfig", "state_dir"): "the run's output directory",
    ("AppConfig", "intake_socket"): "the intake host's namespace, given by the runner when sdn.intake resolves to "
                                    "socket (scenarios.schema.SdnSpec.uses_intake_socket)",
    ("SdcConfig", "sdc_id"): "one per SDC the runner starts (scenarios.configs.sdcs)",
    ("SdcConfig", "role"): "one per SDC the runner starts (scenarios.configs.sdcs)",
    ("SdcConfig", "bind_ip"): "every address of the SDC's namespace; tests bind to the loopback",
    ("SdcConfig", "capacity"): "the topology's number of turbines",
    ("PlantConfig", "turbines"): "the topology's turbine hosts and a process in each one's namespace",
    ("PlantConfig", "check_rx_source"): "always on in a run; tests and benchmarks turn it off",
    ("PlantConfig", "stdin_commands"): "always on in a run (the runner sends the timeline); tests turn it off",
    ("PlantConfig", "t0_wall"): "the run clock's reading at t = 0, set by the plant at start-up",
    ("PlantConfig", "start_margin_wall_s"): "scenarios.configs.START_MARGIN_WALL_S: the runner's and services' "
                                            "time to see plant_ready.json",
    ("ImpairNodeConfig", "name"): "the element host the runner puts into the link (scenarios.impairments)",
    ("ImpairNodeConfig", "intf_a"): "the element host's interface, named by the runner",
    ("ImpairNodeConfig", "intf_b"): "the element host's interface, named by the runner",
    ("ImpairNodeConfig", "a"): "the link's switch as the built topology describes it (the links entry names it)",
    ("ImpairNodeConfig", "b"): "the link's switch as the built topology describes it (the links entry names it)",
    ("ImpairNodeConfig", "spin_us"): "0: the elements sleep, no busy-waiting (docs/scenarios.md)",
    ("ImpairNodeConfig", "status_period_s"): "how often the runner's status view is refreshed",
}

DEPLOYMENT_ONLY = {  # options of a service deployed outside a run (docs/real-devices.md): a run leaves the default
    ("OwfccConfig", "bind_ip"): "a deployed OWFCC's PC may have several addresses; in a run the host has one (and "
                                "tests bind to the loopback)",
    ("OwfccConfig", "stdin_commands"): "false for a deployed OWFCC (under systemd stdin is /dev/null); a run sends "
                                       "the timeline on stdin",
    ("OwfccConfig", "schedule"): "a deployed OWFCC's own timeline; a run's requests come from the scenario's "
                                 "timeline on stdin",
    ("OwfccConfig", "command_socket"): "commands typed on a deployed OWFCC's PC (sdvisc owfcc-send); a run's come "
                                       "on stdin",
}

FROM_SCENARIO = {  # options whose scenario key has another name or place: (process config, option) -> key path
    ("AppConfig", "turbine_fallback_s"): ("plant", "remote_loss_fallback_s"),
    ("AppConfig", "backup_sdc"): ("sdc", "backup"),
    ("PlantConfig", "report_loss_after_s"): ("sdn", "dr_hold_s"),
    ("PlantConfig", "batteries"): ("plant", "batteries", "turbines"),
    ("PlantConfig", "battery_soc_init"): ("plant", "batteries", "soc_init"),
    ("PlantConfig", "prepare_scr"): ("timeline",),
}

SAME_OPTION = [  # one option under two names: the same bounds and default
    ((AppConfig, "turbine_fallback_s"), (PlantSpec, "remote_loss_fallback_s")),
    ((PlantConfig, "battery_soc_init"), (BatterySpec, "soc_init")),
]

HOMONYMS = {  # one name, different things
    "name": "a scenario's name, its topology's name, an impairment element's host name",
    "turbines": "turbines per cluster (topology), the turbine endpoints (plant), the battery turbines",
    "topology": "the scenario's choice of topology; the built topology the SDN app gets",
    "owfcc": "the scenario's OWFCC section; the OWFCC's host name the SDN app gets",
    "batteries": "the scenario's battery section (turbines, soc_init); the plant's battery turbines (their SOC: "
                 "battery_soc_init)",
    "emulate": "an external device made on this machine (yes/no: plant.peer, topology.external_switches); how many "
               "stand-in servers to make (cluster)",
}

BASE = {"name": "t", "duration_s": 2.0, "timeline": [{"t": 0.5, "do": "visc_on", "wt": "wt1_1"}]}
FULL = {"plant": {"model": "full"}}
NEEDS = {  # what a key path needs beside it to be valid
    ("plant", "grid"): FULL, ("plant", "p_star"): FULL,
    ("plant", "batteries"): {"plant": {"model": "full", "batteries": {"turbines": ["wt1_1"]}}},
    ("topology", "onshore_units"): {"topology": {"name": "farm", "clusters": 5, "turbines": 10}, **FULL},
    ("timeline",): FULL,
    ("links",): {"switch_links": "patch", "links": [{"a": "s1", "b": "s3"}]},
}
VALUES = {  # key path -> (value set in the file, value the process config must hold)
    ("duration_s",): (7.0, 7.0),
    ("sdc", "backup"): (False, None),
    ("plant", "record"): (["wt1_2"], ["wt1_2"]),
    ("plant", "p_star"): ({"wt1_1": 0.25}, {"wt1_1": 0.25}),
    ("plant", "batteries", "turbines"): (["wt1_2"], ["wt1_2"]),
    ("plant", "batteries", "soc_init"): (0.7, 0.7),
    ("sdn", "visc_disabled"): (["wt1_2"], ["wt1_2"]),
    ("sdn", "managers"): ([{"name": "duplication", "turbines": ["wt1_2"]}],
                          [ManagerChoice(name="duplication", turbines=["wt1_2"])]),
    ("sdn", "path_policy"): ("delay", "delay"),
    ("sdc", "law"): ("droop", "droop"),
    ("topology", "onshore_units"): (1, 1),
    ("timeline",): ([{"t": 1.0, "do": "scr", "value": 2.5}], [2.5]),
}


# ------------------------------------------------------------------ walking the models

def _models_in(annotation) -> list[type[BaseModel]]:
    """The pydantic models an annotation holds (in lists, dicts, unions, Annotated)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    return [m for arg in typing.get_args(annotation) for m in _models_in(arg)]


def _fields(model: type[BaseModel], path: tuple = ()):
    """(path, owning model, field name, FieldInfo) of every option under ``model``: nested option
    models followed, the timeline (actions, not options) and DATA_MODELS not."""
    for name, info in model.model_fields.items():
        if model is Scenario and name == "timeline":
            continue
        if model is TopologySpec and name == "options":  # each topology's own, beside name in the file
            for topo in topos.values():
                yield from _fields(options_of(topo), path)
            continue
        yield path + (name,), model, name, info
        for sub in _models_in(info.annotation):
            if sub not in DATA_MODELS:
                list_like = typing.get_origin(info.annotation) is list
                yield from _fields(sub, path + (name,) + ((0,) if list_like else ()))


def _constraints(info: FieldInfo) -> list[str]:
    found = [repr(m) for m in info.metadata]

    def walk(annotation):
        if typing.get_origin(annotation) is typing.Annotated:
            for meta in annotation.__metadata__:
                found.extend(repr(m) for m in (meta.metadata if isinstance(meta, FieldInfo) else [meta]))
        for arg in typing.get_args(annotation):
            walk(arg)
    walk(info.annotation)
    return sorted(set(found))


def signature(info: FieldInfo) -> tuple:
    """What must agree where one option is defined: its bounds and its default."""
    return tuple(_constraints(info)), repr(info.get_default(call_default_factory=True))


def defined_differently(models) -> dict[str, list[str]]:
    """Option names defined with more than one signature, and where."""
    seen: dict[str, dict[tuple, list[str]]] = {}
    for model in models:
        for _, owner, name, info in _fields(model):
            seen.setdefault(name, {}).setdefault(signature(info), []).append(owner.__name__)
    return {name: [f"{sorted(set(owners))}: {sig}" for sig, owners in sigs.items()]
            for name, sigs in seen.items() if len(sigs) > 1}


def scenario_keys(config: type[BaseModel], path: tuple) -> list[tuple] | None:
    """The scenario key paths that could set option ``path`` of ``config`` (None: run-derived)."""
    name = path[0]
    if (config.__name__, name) in RUN_DERIVED or ("*", name) in RUN_DERIVED or (config.__name__, name) in DEPLOYMENT_ONLY:
        return None
    if (config.__name__, name) in FROM_SCENARIO:
        return [FROM_SCENARIO[config.__name__, name]]
    return [p for p, _, _, _ in _fields(Scenario) if tuple(k for k in p if k != 0)[-len(path):] == path]


def options(config: type[BaseModel]):
    """(path, FieldInfo) of every option of a process configuration, nested option models expanded."""
    for path, _, _, info in _fields(config):
        if not [m for m in _models_in(info.annotation) if m not in DATA_MODELS]:
            yield path, info


# ------------------------------------------------------------------ a scenario through to the processes

def _merge(into: dict, extra: dict) -> dict:
    for k, v in extra.items():
        into[k] = _merge(dict(into.get(k, {})), v) if isinstance(v, dict) and isinstance(into.get(k), dict) else v
    return into


def _file_with(key: tuple, value) -> dict:
    data = copy.deepcopy(BASE)
    for prefix, extra in NEEDS.items():
        if key[:len(prefix)] == prefix:
            data = _merge(data, copy.deepcopy(extra))
    if key[0] == "links":
        data["links"][0][key[-1]] = value
        return data
    node = data
    for k in key[:-1]:
        node = node.setdefault(k, {})
    node[key[-1]] = value
    return data


def _other_value(info: FieldInfo):
    """A valid value for a key that differs from its default."""
    default, kind = info.get_default(call_default_factory=True), info.annotation
    choices = typing.get_args(kind) if typing.get_origin(kind) is typing.Literal else ()
    if choices:
        return next(c for c in choices if c != default)
    if kind is bool:
        return not default
    bounds = {a: getattr(m, a) for m in info.metadata for a in ("ge", "gt", "le", "lt") if hasattr(m, a)}
    low, high = bounds.get("ge", bounds.get("gt", 0)), bounds.get("le", bounds.get("lt"))
    if kind is int:
        return default + 1 if high is None or default + 1 <= high else default - 1
    start = low if default is None else default
    return (start + high) / 2 if high is not None else (start * 2 or 1.0)


def process_configs(data: dict, tmp_path: Path) -> dict[str, BaseModel]:
    """What the runner writes for the scenario ``data``, each read back from its file."""
    path = tmp_path / "scenario.yaml"
    path.write_text(yaml.safe_dump(data))
    sc = load_scenario(path)
    desc = describe(sc.topology.topo_class()(**sc.topology.params()))
    out = str(tmp_path)
    pids = {n: None for n, h in desc["hosts"].items() if h["role"] == "turbine"}
    _, sdc_id, role = configs.sdcs(sc)[0]
    made = [configs.app_config(sc, desc, out), configs.sdc_config(sc, desc, out, sdc_id, role),
            configs.plant_config(sc, desc, out, pids), configs.owfcc_config(sc, out)]
    impairments = Impairments(sc, tmp_path)
    for pair, imp in impairments.initial.items():  # as scenarios.impairments starts an element
        a, b = sorted(pair)
        made.append(ImpairNodeConfig(name="x1", a=a, b=b, intf_a="x1-eth0", intf_b="x1-eth1", out_dir=out,
                                     seed=impairments.seeds[pair], **imp.as_dict()))
    return {type(cfg).__name__: load_config(type(cfg), write_config(cfg, tmp_path / f"{type(cfg).__name__}.json"))
            for cfg in made}


CASES = [(config, path, info, keys[0]) for config in PROCESS_CONFIGS for path, info in options(config)
         if (keys := scenario_keys(config, path)) is not None and len(keys) == 1]


@pytest.mark.parametrize(("config", "path", "info", "key"), CASES,
                         ids=[f"{c.__name__}.{'.'.join(p)}" for c, p, _, _ in CASES])
def test_every_option_is_set_from_a_scenario_file(config, path, info, key, tmp_path):
    key_info = next(i for p, _, _, i in _fields(Scenario) if p == key) if key != ("timeline",) else None
    value, expected = VALUES.get(key) or (2 * (_other_value(key_info),))
    got = process_configs(_file_with(key, value), tmp_path)[config.__name__]
    for k in path:
        got = getattr(got, k)
    assert got == expected
    assert expected != info.get_default(call_default_factory=True), "the value must not be the default"


def test_every_option_is_accounted_for():
    """Each option of each process configuration: a scenario key sets it, or RUN_DERIVED (or
    DEPLOYMENT_ONLY) says why not."""
    listed = {(c, name) for c, name in RUN_DERIVED | FROM_SCENARIO | DEPLOYMENT_ONLY}
    for config in PROCESS_CONFIGS:
        for path, _ in options(config):
            keys = scenario_keys(config, path)
            assert keys is None or len(keys) == 1, (
                f"{config.__name__}.{'.'.join(path)}: no one scenario key sets it ({keys or 'none'}); add it to a "
                "scenario section (an option group of sdvisc/config.py), FROM_SCENARIO or RUN_DERIVED (with the reason)")
    stale = {(c, n) for c, n in listed
             if c != "*" and n not in next(m for m in PROCESS_CONFIGS if m.__name__ == c).model_fields}
    assert not stale, f"listed but not options: {stale}"


def test_no_option_is_defined_twice_with_other_bounds_or_defaults():
    twice = defined_differently((Scenario, *PROCESS_CONFIGS))
    assert set(twice) <= set(HOMONYMS), "\n".join(f"{n}: {where}" for n, where in twice.items() if n not in HOMONYMS)
    assert set(HOMONYMS) <= set(twice), "a homonym is one option now: drop it from HOMONYMS"
    for (model_a, a), (model_b, b) in SAME_OPTION:
        assert signature(model_a.model_fields[a]) == signature(model_b.model_fields[b]), (a, b)
    assert BATTERY_SOC_LIMITS == (BatteryParams.soc_min, BatteryParams.soc_max)


def test_a_second_definition_with_other_bounds_is_found():
    """The check above can fail: an option defined again with another bound or default is named."""
    class Twice(BaseModel):
        dr_hold_s: float = Field(0.040, gt=0)  # SdnOptions has le=1.0
        record_every: int = Field(10, ge=1)  # PlantOptions: 15

    twice = defined_differently((Scenario, *PROCESS_CONFIGS, Twice))
    assert {"dr_hold_s", "record_every"} <= set(twice)

    class Same(BaseModel):
        dr_hold_s: float = Field(0.040, gt=0, le=1.0)

    assert "dr_hold_s" not in defined_differently((Scenario, *PROCESS_CONFIGS, Same))
