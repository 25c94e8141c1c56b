"""The scenario file schema (pydantic): topology, timing, plant/SDC/SDN settings and a timeline.

Unknown keys and non-finite numbers (NaN, inf) are rejected everywhere. The checks that need more
than one section (timeline times within ``duration_s``, names in the topology, ``set`` parameters
of the plant model) are made by :func:`scenarios.loader.load_scenario`, together with these.
Timeline entries are discriminated by ``do``::

    timeline:
      - {t: 1.0, do: visc_on, wt: wt1_1, params: {h: 3.0, m_q: 0.02}}
      - {t: 2.0, do: link_down, a: s1, b: s3}
      - {t: 2.5, do: kill, host: sdc1, process: sdc}
"""

from __future__ import annotations

from typing import Annotated, Literal, get_args

from pydantic import BaseModel, ConfigDict, Field, ValidationInfo, field_validator, model_validator

from plant.params import BatteryParams, GridParams
from sdvisc.config import GATHER_HELP, GRID_SCENARIO_KEYS
from sdvisc.vocabulary import MAX_ONSHORE_UNITS, ONSHORE_CLUSTER

TURBINE_PATTERN = r"^wt\d+_\d+$"


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class TopologySpec(Strict):
    name: Literal["paper", "farm"] = Field("paper", description="topology in topologies.topos")
    clusters: int = Field(5, ge=1, le=50)
    turbines: int = Field(2, ge=1, le=100, description="turbines per cluster")
    layout: Literal["compact", "tower"] | None = Field(None, description="farm only; default compact")
    onshore_units: int = Field(0, ge=0, le=MAX_ONSHORE_UNITS, description=(
        "farm with plant.model full only: the plant's aggregated onshore units (the paper's comparison "
        "arrangement: one 40 MVA SDViSC at the onshore PCC, PlantParams.onshore_units), each a turbine host "
        f"wt{ONSHORE_CLUSTER}_<k> on the substation switch sub1, plant converter 50 + k - 1; 0 = none"))

    @model_validator(mode="after")
    def _layout_only_for_farm(self):
        if self.layout is not None and self.name != "farm":
            raise ValueError("layout applies to the farm topology only")
        return self

    @field_validator("onshore_units")
    @classmethod
    def _onshore_on_the_farm(cls, value: int, info: ValidationInfo) -> int:
        if value and info.data.get("name", "paper") != "farm":
            raise ValueError("onshore units need the farm topology (their hosts hang on its substation switch sub1)")
        if value and info.data.get("clusters", 0) >= ONSHORE_CLUSTER:
            raise ValueError(f"onshore unit hosts are wt{ONSHORE_CLUSTER}_<k>: at most {ONSHORE_CLUSTER - 1} "
                             f"clusters beside them, not {info.data['clusters']}")
        return value

    def params(self) -> dict:
        p = {"clusters": self.clusters, "turbines": self.turbines}
        if self.name == "farm":
            p["layout"] = self.layout or "compact"
        if self.onshore_units:
            p["onshore_units"] = self.onshore_units
        return p


class GridSourceSpec(Strict):
    """The grid source behind the PCC's Thevenin impedance (``plant.params.GridParams``; full model
    only). Each key left out keeps the plant's default."""

    h: float | None = Field(None, ge=0, le=30, description=(
        f"inertia constant of the grid source on s_mva, s (GridParams.h_grid); 0 = an ideal source whose "
        f"frequency never moves (default {GridParams.h_grid:g})"))
    s_mva: float | None = Field(None, gt=0, le=1e6, description=(
        f"rating of the grid source, MVA (GridParams.s_grid_mva; default {GridParams.s_grid_mva:g} = SCR x 500 MVA)"))
    d: float | None = Field(None, ge=0, le=100, description=(
        f"load damping of the grid source, p.u. power / p.u. speed on s_mva (default {GridParams.d_grid:g})"))
    r_gov: float | None = Field(None, gt=0, le=1, description=(
        f"governor droop, p.u. speed / p.u. power (default {GridParams.r_gov:g}); only with h > 0"))
    t_gov_s: float | None = Field(None, gt=0, le=100, description=(
        f"governor/turbine time constant, s (default {GridParams.t_gov:g})"))
    e: float | None = Field(None, ge=0.8, le=1.2, description=(
        f"magnitude of the grid source's EMF, p.u. (GridParams.e_grid, default {GridParams.e_grid:g}): e.g. the "
        "paper's F8 starts from V_pcc = 0.97"))

    def grid_params(self) -> dict[str, float]:
        """The ``GridParams`` fields these keys set (only those given)."""
        return {GRID_SCENARIO_KEYS[k]: v for k, v in self.model_dump().items() if v is not None}


class BatterySpec(Strict):
    """Li-ion batteries on turbines' DC links from t = 0 (``plant/battery.py``, ``Plant.set_battery``;
    full model only): the paper's 2000 Ah battery of F5."""

    turbines: list[Annotated[str, Field(pattern=TURBINE_PATTERN)]] = Field(
        min_length=1, description="turbines whose DC link gets a battery")
    soc_init: float | None = Field(None, ge=BatteryParams.soc_min, le=BatteryParams.soc_max, description=(
        f"initial state of charge, fraction {BatteryParams.soc_min:g}-{BatteryParams.soc_max:g} (default "
        f"{BatteryParams.soc_init:g}); the pack floats on the DC link at it (BatteryParams.soc_init)"))

    @field_validator("turbines")
    @classmethod
    def _once_each(cls, names: list[str]) -> list[str]:
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise ValueError(f"turbine listed more than once: {', '.join(twice)}")
        return names


class PlantSpec(Strict):
    model: Literal["minimal", "full"] = Field("minimal", description="minimal: infinite bus; full: the 500 MW farm")
    record: list[Annotated[str, Field(pattern=TURBINE_PATTERN)]] | None = Field(
        None, description="turbines in timeseries.csv (default: those named in the timeline)")
    record_every: int = Field(15, ge=1, description="record one sample every N steps")
    ak_period_s: float = Field(0.01, gt=0, le=1.0, description="AK report period")
    ak_window_s: float = Field(0.01, gt=0, le=1.0, description="AK = 1 if a CTRL arrived within this window")
    remote_loss_fallback_s: float = Field(0.1, gt=0, description="remote mode falls back after this loss time")
    remote_apply: Literal["i_ref", "v_ref"] = Field(
        "i_ref", description="what a remote turbine applies: the SDC's current reference (local current loop) "
                             "or its converter voltage reference (inner loop closed over the network)")
    grid: GridSourceSpec | None = Field(None, description="the grid source's inertia and governor (full model)")
    batteries: BatterySpec | None = Field(None, description="batteries on turbines' DC links (full model)")
    p_star: dict[Annotated[str, Field(pattern=TURBINE_PATTERN)], Annotated[float, Field(ge=0, le=1.1)]] | None = Field(
        None, description="grid-following active-power reference P* of these turbines from t = 0, p.u. of the "
                          "turbine rating (the steady state is computed for it; the others follow the MPPT curve: "
                          "1 p.u. at 12 m/s); 0 for a turbine that will run as a ViSC (T_m = 0), full model")

    @field_validator("grid", "batteries", "p_star")
    @classmethod
    def _full_model_only(cls, value, info: ValidationInfo):
        if value is not None and info.data.get("model", "minimal") != "full":
            raise ValueError(f"{info.field_name} needs plant.model: full (the minimal model is an infinite bus)")
        return value


class SdcSpec(Strict):
    method: Literal["tustin", "trapezoid_cumulative", "euler", "hold"] = "tustin"
    dtype: Literal["float64", "float32"] = "float64"
    backup: bool = Field(True, description="start the backup SDC on sdc2")
    gather_steps: float = Field(0.5, ge=0, le=0.9, description=GATHER_HELP)
    standby: Literal["latest", "track"] = Field(
        "latest", description="backup warm state: track = step on every mirrored sample; latest = initialise at take-over")


class SdnSpec(Strict):
    dr_hold_s: float = Field(0.040, gt=0, le=1.0, description="hold before DR_i is confirmed")
    ak_timeout_s: float = Field(0.030, gt=0, le=1.0, description="no AK for this long counts as AK = 0")
    dynamic_routing: bool = Field(True, description="act on DR_i (reroute); false reproduces the no-DR case")
    reroute_on_port_status: bool = Field(False, description="also reroute at once on port-status link down")
    fast_failover: bool = Field(False, description="pre-install OpenFlow fast-failover groups with detours")
    duplicate_paths: bool = Field(False, description="1+1 duplication: each packet also on a second, node-disjoint "
                                  "leg; the receivers drop the copy (PRP-like, docs/sdn.md)")
    redundancy: bool = Field(False, description="run a second SDN app instance as OpenFlow slave that takes over")
    visc_disabled: list[Annotated[str, Field(pattern=TURBINE_PATTERN)]] = Field(default_factory=list)
    failover: bool = Field(True, description="fail turbines over to the backup SDC when the primary dies")
    sdc_dead_s: float = Field(0.030, gt=0, le=1.0, description="an SDC is dead after this long without heartbeat")
    mirror_to_backup: bool = Field(True, description="copy measurements to the backup SDC (warm standby)")


class CaptureSpec(Strict):
    pcap: bool = Field(False, description="capture on the hosts below into DIR/capture_<host>.pcap")
    hosts: list[str] = Field(default_factory=lambda: ["sdc1"])


class LinkRef(Strict):
    a: str = Field(description="a switch at one end of a switch-to-switch link")
    b: str = Field(description="the switch at the other end")


_DELAY = {"ge": 0, "le": 10_000}


class LinkImpairmentSpec(LinkRef):
    """Delay, jitter, loss and bandwidth of one switch-to-switch link, both directions
    (docs/scenarios.md "Impairments"); any subset of the keys."""

    delay_ms: float = Field(0.0, **_DELAY, description="one-way delay added in each direction (simulated ms)")
    jitter_ms: float = Field(0.0, **_DELAY, description="uniform jitter: each frame delay ± jitter (never < 0)")
    loss: float = Field(0.0, ge=0, le=1, description="probability that a frame is dropped")
    bw_mbps: float | None = Field(None, gt=0, le=100_000, description="bandwidth (Mbit/s of simulated time)")
    seed: int = Field(1, description="loss and jitter draws")


class _Event(Strict):
    t: float = Field(ge=0, description="seconds from the scenario start")


class ViscOn(_Event):
    do: Literal["visc_on"]
    wt: str = Field(pattern=TURBINE_PATTERN)
    params: dict[Literal["h", "d", "m_q", "v_ref", "q_ref", "supp"], float] = Field(default_factory=dict)


class ViscOff(_Event):
    do: Literal["visc_off"]
    wt: str = Field(pattern=TURBINE_PATTERN)


class SetViscParams(_Event):
    do: Literal["set_params"]
    wt: str = Field(pattern=TURBINE_PATTERN)
    params: dict[Literal["h", "d", "m_q", "v_ref", "q_ref", "supp"], float]


class LinkDown(_Event):
    do: Literal["link_down"]
    a: str
    b: str


class LinkUp(_Event):
    do: Literal["link_up"]
    a: str
    b: str


class PathLinkDown(_Event):
    """Fail the ``hop``-th switch-to-switch link of the path currently carrying ``wt``'s traffic
    (as the SDN app reports it; counted from the SDC side, modulo the number of such links)."""

    do: Literal["path_link_down"]
    wt: str = Field(pattern=TURBINE_PATTERN)
    hop: int = Field(0, ge=0)


class RestoreLinks(_Event):
    """Bring every link this run took down back up."""

    do: Literal["restore_links"]


class Kill(_Event):
    do: Literal["kill"]
    host: str
    process: Literal["sdc", "controller", "controller2", "owfcc"]
    crash: bool = Field(False, description="a crash, not a planned stop: the runner restarts the service")


class Fuzz(_Event):
    """Send hostile datagrams (random, truncated, bit-flipped and extreme-word copies of real
    messages; :mod:`sdvisc.fuzz`) from ``host``'s own namespace to the testbed ports of
    ``targets`` (host names, or ``controller`` for the SDN app's virtual address)."""

    do: Literal["fuzz"]
    host: str
    targets: list[str] = Field(min_length=1)
    count: int = Field(ge=1, le=1_000_000)
    duration_s: float = Field(gt=0, le=3600)
    seed: int = 1


class SpoofAk(_Event):
    """Send AK messages (``ak`` 0 or 1) for the turbine ``victim`` from ``host``: with ``host``'s
    own addresses, or (``impersonate``) with the victim's IP and MAC — what the SDN app can and
    cannot tell apart (docs/sdn.md)."""

    do: Literal["spoof_ak"]
    host: str
    victim: str = Field(pattern=TURBINE_PATTERN)
    ak: Literal[0, 1] = 0
    impersonate: bool = False
    count: int = Field(100, ge=1, le=100_000)
    duration_s: float = Field(1.0, gt=0, le=3600)


class Impair(_Event):
    """Change the impairment of link ``a``–``b`` (listed in ``links`` or not): the keys given are
    set, the others kept; ``bw_mbps: 0`` removes the bandwidth limit."""

    do: Literal["impair"]
    a: str
    b: str
    delay_ms: float | None = Field(None, **_DELAY)
    jitter_ms: float | None = Field(None, **_DELAY)
    loss: float | None = Field(None, ge=0, le=1)
    bw_mbps: float | None = Field(None, ge=0, le=100_000)

    @model_validator(mode="after")
    def _something_to_change(self):
        if all(getattr(self, k) is None for k in ("delay_ms", "jitter_ms", "loss", "bw_mbps")):
            raise ValueError("impair needs at least one of delay_ms, jitter_ms, loss, bw_mbps")
        return self


class ClearImpairments(_Event):
    """Remove the impairment of link ``a``–``b``, or (without ``a``, ``b``) of every link."""

    do: Literal["clear_impairments"]
    a: str | None = None
    b: str | None = None

    @model_validator(mode="after")
    def _both_ends_or_none(self):
        if (self.a is None) != (self.b is None):
            raise ValueError("give both a and b (one link) or neither (every link)")
        return self


class SetParam(_Event):
    """Set a plant parameter to ``value``, or change it by ``delta`` from what it is at that moment
    (a parameter with a ``get_<param>`` method too, e.g. ``avr_ref``: plant/settable.py)."""

    do: Literal["set"]
    param: str = Field(description="a plant parameter with a one-number set_<param> method of plant.model, e.g. "
                                   "grid_voltage, avr_ref (full); see plant/settable.py")
    value: float | None = Field(None, description="the new value (the parameter's unit, e.g. p.u.)")
    delta: float | None = Field(None, description="added to the parameter's present value (same unit), e.g. "
                                                  "avr_ref +0.04 p.u.")

    @model_validator(mode="after")
    def _value_or_delta(self):
        if (self.value is None) == (self.delta is None):
            raise ValueError("set needs exactly one of value (absolute) and delta (relative)")
        return self


class LoadStep(_Event):
    do: Literal["load_step"]
    mw: float


class Fault(_Event):
    do: Literal["fault"]
    duration_s: float = Field(gt=0, description="cleared after this time")


class Scr(_Event):
    do: Literal["scr"]
    value: float = Field(gt=0)


Event = Annotated[ViscOn | ViscOff | SetViscParams | LinkDown | LinkUp | PathLinkDown | RestoreLinks | Kill | SetParam
                  | LoadStep | Fault | Scr | Fuzz | SpoofAk | Impair | ClearImpairments,
                  Field(discriminator="do")]
EVENT_KINDS = tuple(get_args(cls.model_fields["do"].annotation)[0] for cls in get_args(get_args(Event)[0]))


class Scenario(Strict):
    name: str
    description: str = ""
    topology: TopologySpec = Field(default_factory=TopologySpec)
    duration_s: float | None = Field(gt=0, le=3600, description="simulated seconds; null: open-ended (only with "
                                     "sdvisc run --cli, which ends the session)")
    step_s: float = Field(0.67e-3, gt=0, le=0.1, description="plant/SDC sampling period Ts")
    time_scale: Annotated[float, Field(ge=1.0, le=1000.0)] | Literal["auto"] = Field(
        1.0, description="wall seconds per simulated second (virtual time: every component k times slower, the "
                         "network k times faster); 1 = real time; auto = measured before t = 0 (scenarios.calibrate)")
    switch_ports: Literal["system", "afxdp", "afxdp-nonpmd"] = Field(
        "system", description="the switch side of every link: system (AF_PACKET, ovs-vswitchd's main thread) or "
                              "AF_XDP (afxdp: a PMD thread spinning one core, ~10x cheaper hops; scenarios/switch_ports.py)")
    switch_links: Literal["veth", "patch"] = Field(
        "veth", description="how switches are joined: veth pairs, or Open vSwitch patch ports (one datapath pass "
                            "across every bridge; a failed link is removed; scenarios/switch_links.py)")
    cpu_split: bool = Field(
        False, description="Open vSwitch's threads on a CPU of their own, the run's processes on the others "
                           "(sdvisc/cpu_split.py); nothing with one CPU")
    plant: PlantSpec = Field(default_factory=PlantSpec)
    sdc: SdcSpec = Field(default_factory=SdcSpec)
    sdn: SdnSpec = Field(default_factory=SdnSpec)
    capture: CaptureSpec = Field(default_factory=CaptureSpec)
    links: list[LinkImpairmentSpec] = Field(default_factory=list, description="impaired links from t = 0")
    impairable: Literal["listed", "all"] | list[LinkRef] = Field(
        "listed", description="links that get an impairment element (without netem): those in links and in "
                              "impair actions (listed), every switch-to-switch link (all), or these too")
    timeline: list[Event] = Field(default_factory=list, description="each t <= duration_s (checked by the loader)")

    def turbines_named(self) -> list[str]:
        names = []
        for event in self.timeline:
            wt = getattr(event, "wt", None)
            if wt and wt not in names:
                names.append(wt)
        return names
