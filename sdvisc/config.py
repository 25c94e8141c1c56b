"""One configuration schema for every process of the testbed (pydantic), one error type.

The scenario runner derives each process's configuration from the scenario (scenarios/schema.py)
and writes it as JSON with :func:`write_config`; each process reads it with :func:`load_config`.
Both ends validate against the same model here: an unknown key, a missing one, a wrong type or a
value out of range is a :class:`ConfigError` naming the file, the key and what was expected — at
the runner before a process starts, and again at the process. Defaults live here and nowhere
else (no ``cfg.get(key, default)`` in the services).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Literal, TypeVar

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from sdvisc.clock import Clock
from sdvisc.vocabulary import MAX_ONSHORE_UNITS, TURBINE_PATTERN

CONTROLLER_VIP = "10.0.0.254"
"""The SDN application's virtual IP address (packets to it reach the controller as packet-ins)."""
CONTROLLER_VMAC = "02:00:00:00:00:fe"
"""The SDN application's virtual MAC address."""


class ConfigError(ValueError):
    """A process configuration that cannot be used; the message names the file, key and problem."""


class _Config(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class ClockSettings(_Config):
    """The run's one clock (:mod:`sdvisc.clock`): every process of a run gets the same two numbers."""

    time_scale: float = Field(1.0, ge=1.0, le=1000.0, description="wall seconds per simulated second (k)")
    clock_epoch: float = Field(0.0, ge=0.0, description="wall time at which the virtual clock equals the wall clock")

    def clock(self) -> Clock:
        return Clock(self.time_scale, self.clock_epoch)


class ProcessBase(ClockSettings):
    """What every network process of the testbed needs."""

    controller_vip: str = Field(CONTROLLER_VIP, description="the SDN app's virtual IP address")
    header: bool = Field(True, description="GTNET packets carry the VILLASnode 3-word header")
    out_dir: str = Field(description="where the process writes its ready file, statistics and events")


class ServiceBase(ProcessBase):
    """A process that runs at the sampling period."""

    step_s: float = Field(gt=0, le=0.1, description="sampling period Ts, s")
    realtime_priority: bool = Field(True, description="run at SCHED_FIFO where allowed")


GATHER_HELP = ("after a wake-up, wait up to this many sampling periods (simulated) for the other served "
               "turbines' MEAS, so one round answers them all; 0: every wake-up is a round")


class SdcConfig(ServiceBase):
    """``python -m sdc_unit.service``."""

    sdc_id: int = Field(1, ge=1, le=255)
    role: Literal["primary", "backup"] = "primary"
    standby: Literal["latest", "track"] = Field(
        "latest", description="backup warm state: track = step on every mirrored sample; latest = initialise at take-over")
    bind_ip: str = "0.0.0.0"
    capacity: int = Field(64, ge=1, le=4096, description="turbines one SDC can serve")
    method: Literal["tustin", "trapezoid_cumulative", "euler", "hold"] = "tustin"
    dtype: Literal["float64", "float32"] = "float64"
    gather_steps: float = Field(0.5, ge=0, le=0.9, description=GATHER_HELP)


class TurbineEndpoint(_Config):
    """One turbine's network endpoint in the plant process."""

    name: str = Field(pattern=TURBINE_PATTERN)
    wid: int = Field(ge=101)
    ip: str
    pid: int | None = Field(None, description="a process in the turbine's network namespace (None: this one)")


GRID_SCENARIO_KEYS = {"h": "h_grid", "s_mva": "s_grid_mva", "d": "d_grid", "r_gov": "r_gov", "t_gov_s": "t_gov",
                      "e": "e_grid"}
"""A scenario's ``plant.grid`` keys -> the fields of :class:`GridSourceSettings` (``GridParams``)."""


class GridSourceSettings(_Config):
    """The full model's grid source (``plant.params.GridParams`` fields; None: the plant's default)."""

    h_grid: float | None = Field(None, ge=0, le=30, description="grid source inertia on s_grid_mva, s (0: ideal)")
    s_grid_mva: float | None = Field(None, gt=0, le=1e6, description="grid source rating, MVA")
    d_grid: float | None = Field(None, ge=0, le=100, description="load damping, p.u. power / p.u. speed")
    r_gov: float | None = Field(None, gt=0, le=1, description="governor droop, p.u. speed / p.u. power")
    t_gov: float | None = Field(None, gt=0, le=100, description="governor time constant, s")
    e_grid: float | None = Field(None, ge=0.8, le=1.2, description="grid source EMF magnitude, p.u.")

    def given(self) -> dict[str, float]:
        return {k: v for k, v in self.model_dump().items() if v is not None}


class PlantConfig(ServiceBase):
    """``python -m plant.service``."""

    duration_s: float | None = Field(gt=0, description="simulated seconds to run; None: until a stop command")
    turbines: list[TurbineEndpoint]
    model: Literal["minimal", "full"] = "minimal"
    record: list[str] = Field(default_factory=list, description="turbines whose signals go to timeseries.csv")
    record_every: int = Field(15, ge=1)
    ak_period_s: float = Field(0.01, gt=0, le=1.0)
    ak_window_s: float = Field(0.01, gt=0, le=1.0)
    remote_loss_fallback_s: float = Field(0.1, gt=0)
    remote_apply: Literal["i_ref", "v_ref"] = "i_ref"
    report_loss_after_s: float | None = Field(None, gt=0, description="send an AK at once when a loss lasts this long")
    check_rx_source: bool = Field(True, description="accept CTRL only from the SDC, REQUEST only from the SDN app")
    stdin_commands: bool = Field(True, description="read timeline commands (JSON lines) on stdin")
    t0_wall: float | None = Field(None, description="the run clock's reading at t = 0 (None: set at start-up)")
    start_margin_wall_s: float | None = Field(None, ge=0, description=(
        "t = 0 this many wall seconds after the model is ready (not scaled: the time the runner and the "
        "services need to see plant_ready.json, the same at every time scale)"))
    prepare_scr: list[float] = Field(default_factory=list, description=(
        "SCR values the timeline will set: the full model factorises those network states before t = 0"))
    grid: GridSourceSettings = Field(default_factory=GridSourceSettings, description="full model: the grid source")
    batteries: list[str] = Field(default_factory=list, description="full model: turbines with a battery on the "
                                 "DC link from t = 0 (plant/battery.py)")
    battery_soc_init: float | None = Field(None, ge=0, le=1, description="their initial SOC (None: BatteryParams)")
    p_star: dict[str, float] = Field(default_factory=dict, description="full model: grid-following P* (turbine "
                                     "p.u.) of these turbines from t = 0, the steady state computed for it")
    onshore_units: int = Field(0, ge=0, le=MAX_ONSHORE_UNITS, description=(
        "full model: the aggregated onshore units appended after the farm's turbines (PlantParams.onshore_units); "
        "host wt6_<k> is converter n_farm + k - 1 (sdvisc.vocabulary.ONSHORE_CLUSTER)"))


class OwfccConfig(ProcessBase):
    """``python -m sdvisc.owfcc``."""

    retry_s: float = Field(0.5, gt=0, description="resend an unanswered request after this long")
    max_tries: int = Field(4, ge=1)


class SwitchInfo(_Config):
    dpid: int
    openflow: bool = True


class HostInfo(_Config):
    ip: str
    mac: str
    role: str
    switch: str
    port: int
    cluster: int | None = None
    number: int | None = None


class LinkInfo(_Config):
    a: str
    a_port: int
    b: str
    b_port: int
    element: str | None = Field(None, description="impairment element (host) in the link, transparent at L2")


class TopologyInfo(_Config):
    """A built topology as the processes see it (``topologies.base.describe``)."""

    switches: dict[str, SwitchInfo]
    hosts: dict[str, HostInfo]
    links: list[LinkInfo]


class AppConfig(ClockSettings):
    """``python -m sdn_app``: what the SDN application needs to know at start."""

    topology: TopologyInfo
    controller_vip: str = CONTROLLER_VIP
    controller_vmac: str = CONTROLLER_VMAC
    owfcc: str = "owfcc"
    primary_sdc: str = "sdc1"
    backup_sdc: str | None = "sdc2"
    visc_disabled: list[str] = Field(default_factory=list, description="turbines whose ViSC is not enabled (T2 x/0)")
    dr_hold_s: float = Field(0.040, gt=0, description="hold before DR_i is confirmed, s (paper: 40 ms)")
    ak_timeout_s: float = Field(0.030, gt=0, description="no AK for this long counts as AK = 0, s")
    dynamic_routing: bool = Field(True, description="act on DR_i by rerouting (false: detect and log only)")
    fast_failover: bool = Field(False, description="pre-install fast-failover groups with detours (data-plane repair)")
    reroute_on_port_status: bool = Field(False, description="also reroute at once on a port-status link-down")
    duplicate_paths: bool = Field(False, description="1+1: every packet also on a second, node-disjoint leg "
                                  "between the path's first and last OpenFlow switch (sdn_app.duplication)")
    failover: bool = Field(True, description="fail turbines over to the backup SDC when the primary dies")
    sdc_dead_s: float = Field(0.030, gt=0, description="an SDC is dead after this long without a heartbeat, s")
    mirror_to_backup: bool = Field(True, description="copy measurements to the backup SDC (warm standby)")
    turbine_fallback_s: float = Field(0.1, gt=0, description="a remote turbine without control packets for this "
                                      "long falls back to its own control (plant.remote_loss_fallback_s)")
    state_dir: str | None = Field(None, description="where tables.json, stats.json and events.jsonl are written")
    header: bool = Field(True, description="GTNET packets carry the VILLAS 3-word header")


class ImpairNodeConfig(ClockSettings):
    """``python -m sdvisc.impair_node``: an impairment element forwarding frames between its two
    interfaces (one toward switch ``a``, one toward ``b``) through a timed queue."""

    name: str = Field(description="the element's host name")
    a: str
    b: str
    intf_a: str = Field(description="the element's interface toward a")
    intf_b: str = Field(description="the element's interface toward b")
    out_dir: str
    delay_ms: float = Field(0.0, ge=0, le=10_000)
    jitter_ms: float = Field(0.0, ge=0, le=10_000)
    loss: float = Field(0.0, ge=0, le=1)
    bw_mbps: float | None = Field(None, gt=0, le=100_000)
    seed: int = Field(1, description="loss and jitter draws (numpy generator)")
    realtime_priority: bool = Field(True, description="run at SCHED_FIFO where allowed")
    spin_us: float = Field(0.0, ge=0, le=1000, description="busy-wait this long before a release instead of sleeping")
    status_period_s: float = Field(0.5, gt=0, description="wall seconds between status file writes")


C = TypeVar("C", bound=BaseModel)


def _explain(path: str | Path, exc: ValidationError) -> str:
    lines = []
    for err in exc.errors():
        where = ".".join(str(p) for p in err["loc"]) or "(top level)"
        msg = "unknown key (not allowed here)" if err["type"] == "extra_forbidden" else err["msg"]
        lines.append(f"{path}: {where}: {msg}")
    return "\n".join(lines)


def parse_config(model: type[C], data: dict, source: str | Path = "<config>") -> C:
    """Validate ``data`` as ``model``; :class:`ConfigError` listing every problem otherwise."""
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(_explain(source, exc)) from exc


def load_config(model: type[C], path: str | Path) -> C:
    """Read and validate a process configuration file."""
    try:
        raw = json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise ConfigError(f"{path}: cannot read JSON config: {exc}") from exc
    return parse_config(model, raw, path)


def write_config(config: BaseModel, path: str | Path) -> Path:
    """Write a validated configuration as JSON (what :func:`load_config` reads back)."""
    path = Path(path)
    path.write_text(config.model_dump_json(indent=1))
    return path
