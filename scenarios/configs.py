"""Each process's configuration, derived from a scenario (pure: no Mininet, no files).

The models are :mod:`sdvisc.config`'s; the runner writes what these functions return with
:func:`sdvisc.config.write_config` and each process reads it back through the same model. The
scenario's sections are those models' option groups (:class:`sdvisc.config.SdnOptions`, ...): each
is passed over whole; only what the run derives (topology, out_dir, clock, pids, ...) is added here.
"""

from __future__ import annotations

from scenarios.schema import Scenario
from sdvisc import wire
from sdvisc.config import (
    CONTROLLER_VIP,
    CONTROLLER_VMAC,
    AppConfig,
    IntakeSocket,
    OwfccConfig,
    OwfccOptions,
    PlantConfig,
    PlantOptions,
    SdcConfig,
    SdcOptions,
    SdnOptions,
)

START_MARGIN_WALL_S = 0.5  # t = 0 this many wall seconds after the plant's model is ready (was 0.5 simulated: 8 s at k = 16)


def _options(section, group: type) -> dict:
    """The options of ``group`` (an :mod:`sdvisc.config` option group) that scenario ``section`` holds."""
    return section.model_dump(include=set(group.model_fields))


def framing_header(sc: Scenario) -> bool:
    """Whether the run's GTNET-SKT datagrams carry VILLASnode's header: yes, unless an external peer
    speaks the card's native framing (every process of the run then speaks it too)."""
    return sc.plant.peer is None or sc.plant.peer.framing == "villas"


def sdcs(sc: Scenario) -> list[tuple[str, int, str]]:
    """(host, sdc_id, role) of the SDCs the scenario runs."""
    return [("sdc1", 1, "primary")] + ([("sdc2", 2, "backup")] if sc.sdc.backup else [])


def app_config(sc: Scenario, desc: dict, out_dir: str, clock: dict | None = None,
               intake_pid: int | None = None) -> AppConfig:
    """``intake_pid``: a process in the intake host's namespace when the run has an intake network."""
    return AppConfig(**(clock or {}), **_options(sc.sdn, SdnOptions), topology=desc, controller_vip=CONTROLLER_VIP,
                     controller_vmac=CONTROLLER_VMAC, turbine_fallback_s=sc.plant.remote_loss_fallback_s,
                     backup_sdc="sdc2" if sc.sdc.backup else None, state_dir=out_dir,
                     intake_socket=None if intake_pid is None else IntakeSocket(netns_pid=intake_pid),
                     header=framing_header(sc))


def sdc_config(sc: Scenario, desc: dict, out_dir: str, sdc_id: int, role: str,
               clock: dict | None = None) -> SdcConfig:
    return SdcConfig(**(clock or {}), **_options(sc.sdc, SdcOptions), step_s=sc.step_s, controller_vip=CONTROLLER_VIP,
                     out_dir=out_dir, sdc_id=sdc_id, role=role, header=framing_header(sc),
                     capacity=sum(h["role"] == "turbine" for h in desc["hosts"].values()))


def owfcc_config(sc: Scenario, out_dir: str, clock: dict | None = None) -> OwfccConfig:
    return OwfccConfig(**(clock or {}), **_options(sc.owfcc, OwfccOptions), controller_vip=CONTROLLER_VIP,
                       out_dir=out_dir, header=framing_header(sc))


def plant_config(sc: Scenario, desc: dict, out_dir: str, pids: dict[str, int | None],
                 clock: dict | None = None, open_ended: bool = False) -> PlantConfig:
    """``pids``: a process in each turbine's network namespace (the Mininet host's shell);
    ``open_ended``: the plant runs until it is told to stop (an interactive session), not ``duration_s``.
    A scenario's empty ``plant.record`` records the turbines its timeline names."""
    turbines = [{"name": n, "wid": wire.turbine_id(h["cluster"], h["number"]), "ip": h["ip"], "pid": pids.get(n),
                 "plant_index": h.get("plant_index")}
                for n, h in sorted(desc["hosts"].items()) if h["role"] == "turbine"]
    options = _options(sc.plant, PlantOptions) | {"record": sc.plant.record or sc.turbines_named()}
    batteries = sc.plant.batteries
    return PlantConfig(**(clock or {}), **options, step_s=sc.step_s, controller_vip=CONTROLLER_VIP, out_dir=out_dir,
                       duration_s=None if open_ended else sc.duration_s, turbines=turbines,
                       report_loss_after_s=sc.sdn.dr_hold_s, start_margin_wall_s=START_MARGIN_WALL_S,
                       prepare_scr=sorted({e.value for e in sc.timeline if e.do == "scr"}),
                       batteries=batteries.turbines if batteries else [],
                       battery_soc_init=batteries.soc_init if batteries else None,
                       onshore_units=sc.topology.option("onshore_units", 0))
