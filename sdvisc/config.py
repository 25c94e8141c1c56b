"""One configuration schema for every process of the testbed (pydantic), one error type.

The scenario runner derives each process's configuration from the scenario (scenarios/schema.py)
and writes it as JSON with :func:`write_config`; each process reads it with :func:`load_config`.
Both ends validate against the same model here: an unknown key, a missing one, a wrong type or a
value out of range is a :class:`ConfigError` naming the file, the key and what was expected — at
the runner before a process starts, and again at the process. Defaults live here and nowhere
else (no ``cfg.get(key, default)`` in the services).

Every option a scenario can set is defined once, here (bounds, default, description): in an option
group (:class:`SdnOptions`, :class:`SdcOptions`, :class:`PlantOptions`, :class:`OwfccOptions`,
:class:`GridSourceSettings`, :class:`LinkImpairmentOptions`) or, for a single key, an annotated type
(:data:`StepSeconds`, :data:`RunSeconds`, :data:`TimeScale`, :data:`OnshoreUnits`, ...). The process
configurations include them; the scenario's sections (scenarios/schema.py) subclass the groups,
adding only the keys a scenario alone has, and scenarios/configs.py passes them over whole. Reading
and writing the files (and the error type) is :mod:`sdvisc.config_files`, re-exported here.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

from sdvisc.clock import Clock
from sdvisc.config_files import (  # noqa: F401 - re-exported: the one error type and the file functions, sdvisc.config.*
    ConfigError,
    load_config,
    load_config_or_exit,
    parse_config,
    service_config,
    write_config,
)
from sdvisc.vocabulary import MAX_ONSHORE_UNITS, TURBINE_PATTERN, VISC_PARAMS
from sdvisc.wire_layouts import PORT_TURBINE

CONTROLLER_VIP = "10.0.0.254"
"""The SDN application's virtual IP address (packets to it reach the controller's intake socket, or
the controller as packet-ins)."""
CONTROLLER_VMAC = "02:00:00:00:00:fe"
"""The SDN application's virtual MAC address."""

TurbineName = Annotated[str, Field(pattern=TURBINE_PATTERN)]
"""A turbine host's name, ``wt<cluster>_<number>`` (:data:`sdvisc.vocabulary.TURBINE_PATTERN`)."""
TimeScale = Annotated[float, Field(ge=1.0, le=1000.0)]
"""Wall seconds per simulated second (k); a scenario may also say ``auto``."""
StepSeconds = Annotated[float, Field(0.67e-3, gt=0, le=0.1, description="plant/SDC sampling period Ts, s")]
"""The sampling period (a scenario's ``step_s``, every paced process's)."""
RunSeconds = Annotated[float | None, Field(gt=0, le=3600, description=(
    "simulated seconds to run; null: open-ended, until a stop command (a scenario: only with sdvisc run --cli, "
    "which ends the session)"))]
"""How long a run lasts (a scenario's ``duration_s``, the plant's)."""
OnshoreUnits = Annotated[int, Field(0, ge=0, le=MAX_ONSHORE_UNITS, description=(
    "full model on the farm topology: the plant's aggregated onshore units (the paper's comparison arrangement: one "
    "40 MVA SDViSC at the onshore PCC, PlantParams.onshore_units), appended after the farm's turbines; host wt6_<k> "
    "(sdvisc.vocabulary.ONSHORE_CLUSTER) on the substation switch sub1 is converter n_farm + k - 1; 0 = none"))]
"""A scenario's ``topology.onshore_units``, the plant's."""
FallbackSeconds = Annotated[float, Field(0.1, gt=0, description=(
    "a remote turbine without control packets for this long falls back to its own control (grid following), s"))]
"""A scenario's ``plant.remote_loss_fallback_s``: the plant applies it, the SDN app expects it."""
BATTERY_SOC_LIMITS = (0.1, 0.9)
"""A battery's initial state of charge lies within ``plant.params.BatteryParams`` soc_min, soc_max
(sdvisc does not import the plant; tests/unit/test_one_config_source.py checks that they agree)."""
BatterySoc = Annotated[float, Field(ge=BATTERY_SOC_LIMITS[0], le=BATTERY_SOC_LIMITS[1])]
"""A battery's initial state of charge, fraction."""
DelayMs = Annotated[float, Field(ge=0, le=10_000)]
"""A link's added one-way delay or jitter, simulated ms."""
LossProbability = Annotated[float, Field(ge=0, le=1)]
"""The probability that a link drops a frame."""


class _Config(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class ClockSettings(_Config):
    """The run's one clock (:mod:`sdvisc.clock`): every process of a run gets the same two numbers."""

    time_scale: TimeScale = Field(1.0, description="wall seconds per simulated second (k)")
    clock_epoch: float = Field(0.0, ge=0.0, description="wall time at which the virtual clock equals the wall clock")

    def clock(self) -> Clock:
        return Clock(self.time_scale, self.clock_epoch)


class ControllerAddress(_Config):
    """How a process reaches the SDN application (fixed by the testbed, not a scenario option)."""

    controller_vip: str = Field(CONTROLLER_VIP, description="the SDN app's virtual IP address")
    header: bool = Field(True, description="GTNET packets carry the VILLASnode 3-word header")


class OutputDir(_Config):
    out_dir: str = Field(description="where the process writes its ready file, statistics and events")


class RealtimePriority(_Config):
    realtime_priority: bool = Field(True, description="run at SCHED_FIFO where allowed")


class ProcessBase(ClockSettings, ControllerAddress, OutputDir):
    """What every network process of the testbed needs."""


class ServiceBase(ProcessBase, RealtimePriority):
    """A process that runs at the sampling period."""

    step_s: StepSeconds


class SdcOptions(_Config):
    """The SDC unit's options a scenario sets (its ``sdc`` section)."""

    law: str = Field("visc", pattern=r"^[a-z][a-z0-9_]*$", description=(
        "the control law, a name of sdc_unit.laws.LAWS (visc, hold, droop; the scenario schema checks it)"))
    method: Literal["tustin", "trapezoid_cumulative", "euler", "hold"] = Field(
        "tustin", description="discretisation of the law, one of its methods (the ViSC: all three; a law of the "
                              "generic trapezoid: tustin); hold: the law hold (its former spelling)")
    dtype: Literal["float64", "float32"] = Field("float64", description="the law's floating-point type")
    gather_steps: float = Field(0.5, ge=0, le=0.9, description=(
        "after a wake-up, wait up to this many sampling periods (simulated) for the other served "
        "turbines' MEAS, so one round answers them all; 0: every wake-up is a round"))
    standby: Literal["latest", "track"] = Field(
        "latest", description="backup warm state: track = step on every mirrored sample; latest = initialise at take-over")


class SdcConfig(ServiceBase, SdcOptions):
    """``python -m sdc_unit.service``."""

    sdc_id: int = Field(1, ge=1, le=255)
    role: Literal["primary", "backup"] = "primary"
    bind_ip: str = "0.0.0.0"
    capacity: int = Field(64, ge=1, le=4096, description="turbines one SDC can serve")


class TurbineEndpoint(_Config):
    """One turbine's network endpoint in the plant process."""

    name: TurbineName
    wid: int = Field(ge=101)
    ip: str
    pid: int | None = Field(None, description="a process in the turbine's network namespace (None: this one)")
    plant_index: int | None = Field(None, ge=0, description=(
        "its converter in the full plant model, from the topology's description (HostInfo.plant_index)"))


GRID_SCENARIO_KEYS = {"h": "h_grid", "s_mva": "s_grid_mva", "d": "d_grid", "r_gov": "r_gov", "t_gov_s": "t_gov",
                      "e": "e_grid"}
"""The keys of :class:`GridSourceSettings` (a scenario's ``plant.grid``) -> ``plant.params.GridParams`` fields."""


class GridSourceSettings(_Config):
    """The grid source behind the PCC's Thevenin impedance (``plant.params.GridParams``; full model
    only). Each key left out (None) keeps the plant's default."""

    h: float | None = Field(None, ge=0, le=30, description=(
        "inertia constant of the grid source on s_mva, s (GridParams.h_grid); 0 = an ideal source whose "
        "frequency never moves"))
    s_mva: float | None = Field(None, gt=0, le=1e6, description="rating of the grid source, MVA (GridParams.s_grid_mva)")
    d: float | None = Field(None, ge=0, le=100, description=(
        "load damping of the grid source, p.u. power / p.u. speed on s_mva (GridParams.d_grid)"))
    r_gov: float | None = Field(None, gt=0, le=1, description="governor droop, p.u. speed / p.u. power; only with h > 0")
    t_gov_s: float | None = Field(None, gt=0, le=100, description="governor/turbine time constant, s (GridParams.t_gov)")
    e: float | None = Field(None, ge=0.8, le=1.2, description=(
        "magnitude of the grid source's EMF, p.u. (GridParams.e_grid): e.g. the paper's F8 starts from V_pcc = 0.97"))

    def given(self) -> dict[str, float]:
        """The ``GridParams`` fields these keys set (only those given)."""
        return {GRID_SCENARIO_KEYS[k]: v for k, v in self.model_dump().items() if v is not None}


class PlantOptions(_Config):
    """The plant's options a scenario sets (its ``plant`` section)."""

    model: Literal["minimal", "full", "emt", "external"] = Field("minimal", description=(
        "minimal: infinite bus; full: the 500 MW farm; emt: EMT on DPsim (the emt extra): with topology.onshore_units "
        "1 the paper's comparison arrangement (the onshore SDViSC wt6_1 beside the aggregated farm, "
        "plant/emt/service_backend.py), without onshore units F8's farm (the four SDViSCs wt3_1..wt3_4, "
        "plant/emt/farm_service.py); "
        "external: no plant process, an external GTNET-SKT peer (a scenario's plant.peer) sends the turbines' "
        "measurements"))
    record: list[TurbineName] = Field(default_factory=list, description=(
        "turbines whose signals go to timeseries.csv (a scenario's empty list: those its timeline names)"))
    record_every: int = Field(15, ge=1, description="record one sample every N steps")
    ak_period_s: float = Field(0.01, gt=0, le=1.0, description="AK report period, s")
    ak_window_s: float = Field(0.01, gt=0, le=1.0, description="AK = 1 if a CTRL arrived within this window, s")
    remote_loss_fallback_s: FallbackSeconds
    remote_apply: Literal["i_ref", "v_ref"] = Field(
        "i_ref", description="what a remote turbine applies: the SDC's current reference (local current loop) "
                             "or its converter voltage reference (inner loop closed over the network)")
    grid: GridSourceSettings = Field(default_factory=GridSourceSettings, description="full model: the grid source")
    p_star: dict[TurbineName, Annotated[float, Field(ge=0, le=1.1)]] = Field(default_factory=dict, description=(
        "full model: grid-following active-power reference P* of these turbines from t = 0, p.u. of the turbine "
        "rating (the steady state is computed for it; the others follow the MPPT curve: 1 p.u. at 12 m/s); 0 for "
        "a turbine that will run as a ViSC (T_m = 0)"))


class PlantConfig(ServiceBase, PlantOptions):
    """``python -m plant.service``."""

    @field_validator("model")
    @classmethod
    def _a_model_to_run(cls, value: str) -> str:
        if value == "external":
            raise ValueError("an external plant has no plant process (the GTNET-SKT peer is the plant)")
        return value

    duration_s: RunSeconds
    turbines: list[TurbineEndpoint]
    report_loss_after_s: float | None = Field(None, gt=0, description="send an AK at once when a loss lasts this long")
    check_rx_source: bool = Field(True, description="accept CTRL only from the SDC, REQUEST only from the SDN app")
    stdin_commands: bool = Field(True, description="read timeline commands (JSON lines) on stdin")
    t0_wall: float | None = Field(None, description="the run clock's reading at t = 0 (None: set at start-up)")
    start_margin_wall_s: float | None = Field(None, ge=0, description=(
        "t = 0 this many wall seconds after the model is ready (not scaled: the time the runner and the "
        "services need to see plant_ready.json, the same at every time scale)"))
    prepare_scr: list[float] = Field(default_factory=list, description=(
        "SCR values the timeline will set: the full model factorises those network states before t = 0"))
    batteries: list[TurbineName] = Field(default_factory=list, description=(
        "full model: turbines with a battery on the DC link from t = 0 (plant/battery.py)"))
    battery_soc_init: BatterySoc | None = Field(None, description="their initial SOC (None: BatteryParams.soc_init)")
    onshore_units: OnshoreUnits


class OwfccOptions(_Config):
    """The OWFCC's options a scenario sets (its ``owfcc`` section)."""

    retry_s: float = Field(0.5, gt=0, description="resend an unanswered request after this long, s")
    max_tries: int = Field(4, ge=1, description="send a request at most this many times")


class ScheduledCommand(_Config):
    """One command of a deployed OWFCC's ``schedule`` (what a stdin or command-socket line says)."""

    t_s: float = Field(ge=0, description="send it this many simulated seconds after the OWFCC starts")
    cmd: Literal["visc_on", "visc_off", "set_params"]
    wt: TurbineName
    params: dict[str, float] = Field(default_factory=dict, description=(
        "ViSC parameters by name (h, d, m_q, v_ref, q_ref, supp), as in a scenario's visc_on/set_params"))

    @field_validator("params")
    @classmethod
    def _known_params(cls, params: dict[str, float]) -> dict[str, float]:
        unknown = sorted(set(params) - set(VISC_PARAMS))
        if unknown:
            raise ValueError(f"unknown ViSC parameter(s) {', '.join(unknown)}; known: {', '.join(VISC_PARAMS)}")
        return params


class OwfccConfig(ProcessBase, OwfccOptions):
    """``python -m owfcc.service`` (the runner's) or ``sdvisc owfcc`` (a deployed one: its
    commands from ``schedule`` and ``command_socket``, ``stdin_commands: false``)."""

    bind_ip: str = Field("0.0.0.0", description="address of the socket that sends REQUESTs and receives REPLYs")
    stdin_commands: bool = Field(True, description=(
        "read commands (JSON lines) on stdin, and stop at its end once every request is answered or given "
        "up (the runner's); false: stdin is not read, the OWFCC runs until SIGTERM (a deployed one)"))
    schedule: list[ScheduledCommand] = Field(default_factory=list, description=(
        "commands sent at these simulated times after start (a deployed OWFCC's timeline)"))
    command_socket: str | None = Field(None, description=(
        "path of a Unix datagram socket on which JSON-line commands are accepted (sdvisc owfcc-send)"))


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
    udp_port: int = Field(PORT_TURBINE, ge=1, le=65535, description=(
        "the UDP port the turbine's endpoint listens on and sends from (a GTNET-SKT card serving "
        "several turbines from one IP: one port each)"))
    plant_index: int | None = Field(None, ge=0, description=(
        "a turbine's converter in the full plant model, written by its topology (topologies.base.plant_index)"))


class LinkInfo(_Config):
    a: str
    a_port: int
    b: str
    b_port: int
    element: str | None = Field(None, description="impairment element (host) in the link, transparent at L2")
    delay_s: float = Field(0.0, ge=0, le=10.0, description=(
        "the link's one-way delay, s, from the topology's link options (0: unknown; the delay path policy "
        "then counts the link as a hop only, sdn_app.path_policies.delay)"))


class TopologyInfo(_Config):
    """A built topology as the processes see it (``topologies.base.describe``)."""

    switches: dict[str, SwitchInfo]
    hosts: dict[str, HostInfo]
    links: list[LinkInfo]
    intake_ports: dict[str, int] = Field(default_factory=dict, description=(
        "OpenFlow switch -> its port toward the controller's intake network (topologies.base.add_intake)"))


class ManagerChoice(_Config):
    """One entry of ``sdn.managers``: an SDN manager and the turbines it acts for."""

    name: str = Field(description="the manager's name in sdn_app.managers.MANAGERS")
    turbines: list[TurbineName] | None = Field(None, description="the turbines it acts for; null: every turbine")


class SdnOptions(_Config):
    """The SDN application's options a scenario sets (its ``sdn`` section)."""

    visc_disabled: list[TurbineName] = Field(default_factory=list, description=(
        "turbines whose ViSC is not enabled (T2 x/0)"))
    dr_hold_s: float = Field(0.040, gt=0, le=1.0, description="hold before DR_i is confirmed, s (paper: 40 ms)")
    ak_timeout_s: float = Field(0.030, gt=0, le=1.0, description="no AK for this long counts as AK = 0, s")
    dynamic_routing: bool = Field(True, description=(
        "act on DR_i by rerouting (false: detect and log only, the paper's case without DR)"))
    fast_failover: bool = Field(False, description="pre-install OpenFlow fast-failover groups with detours "
                                "(data-plane repair)")
    reroute_on_port_status: bool = Field(False, description="also reroute at once on a port-status link-down")
    duplicate_paths: bool = Field(False, description=(
        "1+1: every packet also on a second, node-disjoint leg between the path's first and last OpenFlow switch; "
        "the receivers drop the copy (PRP-like, sdn_app.duplication, docs/sdn.md)"))
    failover: bool = Field(True, description="fail turbines over to the backup SDC when the primary dies")
    sdc_dead_s: float = Field(0.030, gt=0, le=1.0, description="an SDC is dead after this long without a heartbeat, s")
    mirror_to_backup: bool = Field(True, description="copy measurements to the backup SDC (warm standby)")
    intake: Literal["auto", "socket", "packet_in"] = Field("auto", description=(
        "how AKs, heartbeats, requests and replies reach the app: socket (the switches forward them to the "
        "app's UDP socket on an intake network, batched per wake-up), packet_in (OpenFlow packet-ins), auto "
        "(socket unless a redundant pair runs: its slave must see what the master sees)"))
    managers: list[ManagerChoice] = Field(default_factory=list, description=(
        "SDN managers (sdn_app.managers.MANAGERS) and the turbines each acts for; an entry replaces what the "
        "booleans above give that manager (every turbine), turbines: [] switches it off (SdnOptions.manager_selection)"))
    path_policy: str = Field("hops", description=(
        "how paths are chosen: a name in sdn_app.path_policies.PATH_POLICIES (hops, the default: fewest hops; "
        "each policy's module says what it prefers)"))

    @field_validator("managers")
    @classmethod
    def _each_manager_once(cls, value: list[ManagerChoice]) -> list[ManagerChoice]:
        names = [m.name for m in value]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise ValueError(f"each manager may be listed once; listed more than once: {twice}")
        return value

    def manager_selection(self) -> dict[str, frozenset[str] | None]:
        """The one place the booleans map onto managers: manager name -> the turbines it acts for
        (None: every turbine). The booleans give their manager for every turbine (the ingress guard
        is always on); an entry of ``managers`` replaces that manager's selection."""
        by_boolean = {"ingress_guard": True, "dynamic_routing": self.dynamic_routing,
                      "port_status_reroute": self.reroute_on_port_status, "fast_failover": self.fast_failover,
                      "duplication": self.duplicate_paths, "mirror": self.failover and self.mirror_to_backup}
        chosen: dict[str, frozenset[str] | None] = {n: None for n, on in by_boolean.items() if on}
        for choice in self.managers:
            chosen[choice.name] = None if choice.turbines is None else frozenset(choice.turbines)
        return {n: t for n, t in chosen.items() if t is None or t}


class IntakeSocket(_Config):
    """Where the SDN app's intake socket is opened (bound to the controller's IP and UDP port)."""

    netns_pid: int | None = Field(None, description="a process in the intake host's network namespace "
                                  "(None: the app's own)")


class AppConfig(ClockSettings, ControllerAddress, SdnOptions):
    """``python -m sdn_app``: what the SDN application needs to know at start."""

    topology: TopologyInfo
    controller_vmac: str = CONTROLLER_VMAC
    owfcc: str = "owfcc"
    primary_sdc: str = "sdc1"
    backup_sdc: str | None = "sdc2"
    turbine_fallback_s: FallbackSeconds
    state_dir: str | None = Field(None, description="where tables.json, stats.json and events.jsonl are written")
    intake_socket: IntakeSocket | None = Field(None, description=(
        "the intake socket, when the switches forward to one (intake resolved to socket by the runner)"))


class LinkEnds(_Config):
    a: str = Field(description="a switch at one end of a switch-to-switch link")
    b: str = Field(description="the switch at the other end")


class LinkImpairmentOptions(_Config):
    """Delay, jitter, loss and bandwidth of one switch-to-switch link, both directions (a scenario's
    ``links`` entries; docs/scenarios.md "Impairments")."""

    delay_ms: DelayMs = Field(0.0, description="one-way delay added in each direction (simulated ms)")
    jitter_ms: DelayMs = Field(0.0, description="uniform jitter: each frame delay ± jitter (never < 0)")
    loss: LossProbability = Field(0.0, description="probability that a frame is dropped")
    bw_mbps: float | None = Field(None, gt=0, le=100_000, description="bandwidth (Mbit/s of simulated time)")
    seed: int = Field(1, description="loss and jitter draws (numpy generator)")


class ImpairNodeConfig(ClockSettings, OutputDir, RealtimePriority, LinkEnds, LinkImpairmentOptions):
    """``python -m impairment.element``: an impairment element forwarding frames between its two
    interfaces (one toward switch ``a``, one toward ``b``) through a timed queue."""

    name: str = Field(description="the element's host name")
    intf_a: str = Field(description="the element's interface toward a")
    intf_b: str = Field(description="the element's interface toward b")
    spin_us: float = Field(0.0, ge=0, le=1000, description="busy-wait this long before a release instead of sleeping")
    status_period_s: float = Field(0.5, gt=0, description="wall seconds between status file writes")
