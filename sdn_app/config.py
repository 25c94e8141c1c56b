"""The SDN application's configuration (written by the scenario runner), checked against a schema."""

from __future__ import annotations

import json
from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field, ValidationError


class ConfigError(ValueError):
    """The one error type for a bad SDN application configuration."""


class SwitchInfo(BaseModel):
    model_config = ConfigDict(extra="forbid")
    dpid: int
    openflow: bool = True


class HostInfo(BaseModel):
    model_config = ConfigDict(extra="forbid")
    ip: str
    mac: str
    role: str
    switch: str
    port: int
    cluster: int | None = None
    number: int | None = None


class LinkInfo(BaseModel):
    model_config = ConfigDict(extra="forbid")
    a: str
    a_port: int
    b: str
    b_port: int


class TopologyInfo(BaseModel):
    model_config = ConfigDict(extra="forbid")
    switches: dict[str, SwitchInfo]
    hosts: dict[str, HostInfo]
    links: list[LinkInfo]


class AppConfig(BaseModel):
    """What the app needs to know at start; the runner writes it as JSON."""

    model_config = ConfigDict(extra="forbid")
    topology: TopologyInfo
    controller_vip: str = "10.0.0.254"
    controller_vmac: str = "02:00:00:00:00:fe"
    owfcc: str = "owfcc"
    primary_sdc: str = "sdc1"
    backup_sdc: str | None = "sdc2"
    visc_disabled: list[str] = Field(default_factory=list, description="turbines whose ViSC is not enabled (T2 x/0)")
    dr_hold_s: float = Field(0.040, gt=0, description="hold before DR_i is confirmed, s (paper: 40 ms)")
    ak_timeout_s: float = Field(0.030, gt=0, description="no AK for this long counts as AK = 0, s")
    dynamic_routing: bool = Field(True, description="act on DR_i by rerouting (false: detect and log only)")
    fast_failover: bool = Field(False, description="pre-install fast-failover groups with detours (data-plane repair)")
    reroute_on_port_status: bool = Field(False, description="also reroute at once on a port-status link-down")
    failover: bool = Field(True, description="fail turbines over to the backup SDC when the primary dies")
    sdc_dead_s: float = Field(0.030, gt=0, description="an SDC is dead after this long without a heartbeat, s")
    mirror_to_backup: bool = Field(True, description="copy measurements to the backup SDC (warm standby)")
    state_dir: str | None = Field(None, description="where tables.json, stats.json and events.jsonl are written")
    header: bool = Field(True, description="GTNET packets carry the VILLAS 3-word header")


def load_config(path: str | Path) -> AppConfig:
    """Read and validate ``path``; raise :class:`ConfigError` naming the file and key."""
    try:
        raw = json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise ConfigError(f"{path}: cannot read JSON config: {exc}") from exc
    try:
        return AppConfig.model_validate(raw)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first["loc"])
        raise ConfigError(f"{path}: {where}: {first['msg']}") from exc
