"""Each process's configuration, derived from a scenario (pure: no Mininet, no files).

The models are :mod:`sdvisc.config`'s; the runner writes what these functions return with
:func:`sdvisc.config.write_config` and each process reads it back through the same model.
"""

from __future__ import annotations

from scenarios.schema import Scenario
from sdvisc import wire
from sdvisc.config import (
    CONTROLLER_VIP,
    CONTROLLER_VMAC,
    AppConfig,
    GridSourceSettings,
    OwfccConfig,
    PlantConfig,
    SdcConfig,
)

START_MARGIN_WALL_S = 0.5  # t = 0 this many wall seconds after the plant's model is ready (was 0.5 simulated: 8 s at k = 16)


def sdcs(sc: Scenario) -> list[tuple[str, int, str]]:
    """(host, sdc_id, role) of the SDCs the scenario runs."""
    return [("sdc1", 1, "primary")] + ([("sdc2", 2, "backup")] if sc.sdc.backup else [])


def app_config(sc: Scenario, desc: dict, out_dir: str, clock: dict | None = None) -> AppConfig:
    return AppConfig(**(clock or {}), topology=desc, controller_vip=CONTROLLER_VIP, controller_vmac=CONTROLLER_VMAC,
                     visc_disabled=sc.sdn.visc_disabled, dr_hold_s=sc.sdn.dr_hold_s, ak_timeout_s=sc.sdn.ak_timeout_s,
                     dynamic_routing=sc.sdn.dynamic_routing, reroute_on_port_status=sc.sdn.reroute_on_port_status,
                     failover=sc.sdn.failover, fast_failover=sc.sdn.fast_failover,
                     duplicate_paths=sc.sdn.duplicate_paths, sdc_dead_s=sc.sdn.sdc_dead_s,
                     mirror_to_backup=sc.sdn.mirror_to_backup, turbine_fallback_s=sc.plant.remote_loss_fallback_s,
                     backup_sdc="sdc2" if sc.sdc.backup else None, state_dir=out_dir)


def sdc_config(sc: Scenario, desc: dict, out_dir: str, sdc_id: int, role: str,
               clock: dict | None = None) -> SdcConfig:
    return SdcConfig(**(clock or {}), step_s=sc.step_s, controller_vip=CONTROLLER_VIP, out_dir=out_dir, sdc_id=sdc_id, role=role,
                     method=sc.sdc.method, dtype=sc.sdc.dtype, standby=sc.sdc.standby,
                     gather_steps=sc.sdc.gather_steps,
                     capacity=sum(h["role"] == "turbine" for h in desc["hosts"].values()))


def owfcc_config(sc: Scenario, out_dir: str, clock: dict | None = None) -> OwfccConfig:
    return OwfccConfig(**(clock or {}), controller_vip=CONTROLLER_VIP, out_dir=out_dir)


def plant_config(sc: Scenario, desc: dict, out_dir: str, pids: dict[str, int | None],
                 clock: dict | None = None, open_ended: bool = False) -> PlantConfig:
    """``pids``: a process in each turbine's network namespace (the Mininet host's shell);
    ``open_ended``: the plant runs until it is told to stop (an interactive session), not ``duration_s``."""
    turbines = [{"name": n, "wid": wire.turbine_id(h["cluster"], h["number"]), "ip": h["ip"], "pid": pids.get(n)}
                for n, h in sorted(desc["hosts"].items()) if h["role"] == "turbine"]
    p = sc.plant
    return PlantConfig(**(clock or {}), step_s=sc.step_s, controller_vip=CONTROLLER_VIP, out_dir=out_dir,
                       duration_s=None if open_ended else sc.duration_s,
                       turbines=turbines, model=p.model, record=p.record or sc.turbines_named(),
                       record_every=p.record_every, ak_period_s=p.ak_period_s, ak_window_s=p.ak_window_s,
                       remote_loss_fallback_s=p.remote_loss_fallback_s, remote_apply=p.remote_apply,
                       report_loss_after_s=sc.sdn.dr_hold_s, start_margin_wall_s=START_MARGIN_WALL_S,
                       prepare_scr=sorted({e.value for e in sc.timeline if e.do == "scr"}),
                       grid=GridSourceSettings(**(p.grid.grid_params() if p.grid else {})),
                       batteries=p.batteries.turbines if p.batteries else [],
                       battery_soc_init=p.batteries.soc_init if p.batteries else None, p_star=p.p_star or {},
                       onshore_units=sc.topology.onshore_units)
