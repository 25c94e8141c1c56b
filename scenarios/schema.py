"""The scenario file schema (pydantic): topology, timing, plant/SDC/SDN settings and a timeline.

The sections that configure a process (``plant``, ``sdc``, ``sdn``, ``owfcc``, ``links`` entries, the
grid source) and the keys ``step_s``, ``duration_s``, ``time_scale`` are :mod:`sdvisc.config`'s option
groups and types, subclassed here only to add what a scenario alone has (``sdc.backup``,
``sdn.redundancy``, ``plant.batteries``, the full-model-only checks): each option's bounds, default
and description are defined once, there.

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

from plant.params import BatteryParams
from scenarios.cluster_spec import ClusterSpec
from scenarios.external_spec import PeerSpec
from scenarios.topology_spec import TopologySpec
from sdc_unit.laws import LAWS
from sdn_app.managers import MANAGERS
from sdn_app.path_policies import PATH_POLICIES
from sdvisc.config import (
    BatterySoc,
    DelayMs,
    GridSourceSettings,
    LinkEnds,
    LinkImpairmentOptions,
    LossProbability,
    OwfccOptions,
    PlantOptions,
    RunSeconds,
    SdcOptions,
    SdnOptions,
    StepSeconds,
    TimeScale,
    TurbineName,
)
from sdvisc.vocabulary import VISC_PARAMS

RuntimeParamName = Literal[tuple(VISC_PARAMS)]
"""A run-time parameter a REQUEST can set (h, d, m_q, v_ref, q_ref, supp: sdvisc.wire_layouts.RUNTIME_PARAM_WORDS)."""


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class BatterySpec(Strict):
    """Li-ion batteries on turbines' DC links from t = 0 (``plant/battery.py``, ``Plant.set_battery``;
    full model only): the paper's 2000 Ah battery of F5."""

    turbines: list[TurbineName] = Field(min_length=1, description="turbines whose DC link gets a battery")
    soc_init: BatterySoc | None = Field(None, description=(
        f"initial state of charge, fraction {BatteryParams.soc_min:g}-{BatteryParams.soc_max:g} (default "
        f"{BatteryParams.soc_init:g}); the pack floats on the DC link at it (BatteryParams.soc_init)"))

    @field_validator("turbines")
    @classmethod
    def _once_each(cls, names: list[str]) -> list[str]:
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise ValueError(f"turbine listed more than once: {', '.join(twice)}")
        return names


class PlantSpec(PlantOptions):
    """The ``plant`` section: :class:`sdvisc.config.PlantOptions` and the batteries (the plant
    configuration's ``batteries`` and ``battery_soc_init``)."""

    batteries: BatterySpec | None = Field(None, description="batteries on turbines' DC links (full model)")
    peer: PeerSpec | None = Field(None, description="model external: the GTNET-SKT peer in place of the plant")

    @model_validator(mode="after")
    def _peer_with_external(self):
        if (self.model == "external") != (self.peer is not None):
            raise ValueError("plant.model: external needs plant.peer (the GTNET-SKT peer), and peer needs model external")
        return self

    @field_validator("grid", "batteries", "p_star")
    @classmethod
    def _full_model_only(cls, value, info: ValidationInfo):
        given = value.given() if isinstance(value, GridSourceSettings) else value
        model = info.data.get("model", "minimal")
        if given and model != "full" and not (model == "emt" and info.field_name != "batteries"):
            raise ValueError(f"{info.field_name} needs plant.model: full{' or emt' * (info.field_name != 'batteries')} "
                             f"(the minimal model is an infinite bus; the EMT arrangement has no batteries)")
        return value


class SdcSpec(SdcOptions):
    """The ``sdc`` section: :class:`sdvisc.config.SdcOptions` and whether a backup SDC runs."""

    backup: bool = Field(True, description="start the backup SDC on sdc2")

    @model_validator(mode="after")
    def _known_law_and_method(self):
        """``law`` from the SDC's registry (sdc_unit.laws.LAWS), ``method`` one of that law's."""
        law = LAWS.get(self.law)
        if law is None:
            raise ValueError(f"sdc.law: unknown law {self.law!r}; known: {', '.join(LAWS)}")
        if law.methods and self.method not in (*law.methods, "hold"):  # hold: the law hold's former spelling
            raise ValueError(f"sdc.method: {self.method!r} is not a method of the law {self.law!r} "
                             f"({', '.join(law.methods)})")
        return self


class SdnSpec(SdnOptions):
    """The ``sdn`` section: :class:`sdvisc.config.SdnOptions` and whether a second SDN app runs."""

    redundancy: bool = Field(False, description="run a second SDN app instance as OpenFlow slave that takes over")

    @model_validator(mode="after")
    def _known_managers_and_path_policy(self):
        """Names from the SDN app's registries (sdn_app.managers, sdn_app.path_policies)."""
        unknown = sorted({m.name for m in self.managers} - set(MANAGERS))
        if unknown:
            raise ValueError(f"managers: unknown {unknown}; known: {sorted(MANAGERS)}")
        if self.path_policy not in PATH_POLICIES:
            raise ValueError(f"path_policy: unknown {self.path_policy!r}; known: {sorted(PATH_POLICIES)}")
        return self

    @model_validator(mode="after")
    def _one_intake_socket(self):
        if self.redundancy and self.intake == "socket":
            raise ValueError("intake: socket serves one SDN app; a redundant pair needs packet_in (or auto), "
                             "so that the slave sees what the master sees")
        return self

    def uses_intake_socket(self, has_openflow_switch: bool) -> bool:
        """True if the run forwards the controller's datagrams to the app's socket."""
        return self.intake != "packet_in" and not self.redundancy and has_openflow_switch


class CaptureSpec(Strict):
    pcap: bool = Field(False, description="capture on the hosts below into DIR/capture_<host>.pcap")
    hosts: list[str] = Field(default_factory=lambda: ["sdc1"])


class LinkRef(LinkEnds):
    """A switch-to-switch link, by its two switches."""


class LinkImpairmentSpec(LinkRef, LinkImpairmentOptions):
    """A ``links`` entry: :class:`sdvisc.config.LinkImpairmentOptions` of the link ``a``–``b``; any
    subset of the keys."""


class _Event(Strict):
    t: float = Field(ge=0, description="seconds from the scenario start")


class ViscOn(_Event):
    do: Literal["visc_on"]
    wt: TurbineName
    params: dict[RuntimeParamName, float] = Field(default_factory=dict)


class ViscOff(_Event):
    do: Literal["visc_off"]
    wt: TurbineName


class SetViscParams(_Event):
    do: Literal["set_params"]
    wt: TurbineName
    params: dict[RuntimeParamName, float]


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
    wt: TurbineName
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
    messages; :mod:`host_tools.fuzz`) from ``host``'s own namespace to the testbed ports of
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
    victim: TurbineName
    ak: Literal[0, 1] = 0
    impersonate: bool = False
    count: int = Field(100, ge=1, le=100_000)
    duration_s: float = Field(1.0, gt=0, le=3600)
    seq0: int = Field(100_000, ge=0, le=2**31 - 1)  # the forged AK counter's first value
    ctrl_rx: int | None = Field(None, ge=0, le=2**31 - 1)  # the forged AKs' ctrl_rx (None: the counter's)


class Impair(_Event):
    """Change the impairment of link ``a``–``b`` (listed in ``links`` or not): the keys given are
    set, the others kept; ``bw_mbps: 0`` removes the bandwidth limit."""

    do: Literal["impair"]
    a: str
    b: str
    delay_ms: DelayMs | None = None
    jitter_ms: DelayMs | None = None
    loss: LossProbability | None = None
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


class ServerDown(_Event):
    """A stand-in server of ``cluster.emulate`` is lost: every process in its namespaces is killed (its
    Open vSwitch, sshd, host shells and services), as if the machine lost power."""

    do: Literal["server_down"]
    server: str


class Fault(_Event):
    do: Literal["fault"]
    duration_s: float = Field(gt=0, description="cleared after this time")


class Scr(_Event):
    do: Literal["scr"]
    value: float = Field(gt=0)


Event = Annotated[ViscOn | ViscOff | SetViscParams | LinkDown | LinkUp | PathLinkDown | RestoreLinks | Kill | SetParam
                  | LoadStep | Fault | Scr | Fuzz | SpoofAk | Impair | ClearImpairments | ServerDown,
                  Field(discriminator="do")]
EVENT_KINDS = tuple(get_args(cls.model_fields["do"].annotation)[0] for cls in get_args(get_args(Event)[0]))


class Scenario(Strict):
    name: str
    description: str = ""
    topology: TopologySpec = Field(default_factory=TopologySpec)
    duration_s: RunSeconds
    step_s: StepSeconds
    time_scale: TimeScale | Literal["auto"] = Field(
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
                           "(host_tools/cpu_split.py); nothing with one CPU")
    switch_revalidation_ms: int | None = Field(
        None, ge=100, le=60_000, description="Open vSwitch's periodic flow revalidation every this many ms while "
        "the run lasts (null: its own 500 ms); changes of flows and ports still revalidate at once "
        "(host_tools/ovs_revalidation.py)")
    plant: PlantSpec = Field(default_factory=PlantSpec)
    sdc: SdcSpec = Field(default_factory=SdcSpec)
    sdn: SdnSpec = Field(default_factory=SdnSpec)
    owfcc: OwfccOptions = Field(default_factory=OwfccOptions)
    capture: CaptureSpec = Field(default_factory=CaptureSpec)
    links: list[LinkImpairmentSpec] = Field(default_factory=list, description="impaired links from t = 0")
    impairable: Literal["listed", "all"] | list[LinkRef] = Field(
        "listed", description="links that get an impairment element (without netem): those in links and in "
                              "impair actions (listed), every switch-to-switch link (all), or these too")
    timeline: list[Event] = Field(default_factory=list, description="each t <= duration_s (checked by the loader)")
    cluster: ClusterSpec | None = Field(None, description=(
        "the network across servers with Mininet's cluster mode (scenarios/cluster_spec.py, docs/cluster.md)"))

    @model_validator(mode="after")
    def _external_plant_time(self):
        peer = self.plant.peer
        if peer is not None and self.time_scale == "auto":
            raise ValueError("time_scale: auto measures the run's plant; with an external peer give a number "
                             "(1 for a real card: an RTDS runs in real time)")
        if peer is not None and not peer.emulate and self.time_scale != 1:
            raise ValueError(f"a real GTNET-SKT peer runs in real time: time_scale must be 1, not {self.time_scale}")
        real = sorted(n for n, spec in self.topology.external_switches.items() if not spec.emulate)
        if real and self.time_scale == "auto":
            raise ValueError(f"time_scale: auto installs its probe flows with ovs-ofctl on every switch; the real "
                             f"switches {', '.join(real)} are not this machine's: give a number")
        return self

    @model_validator(mode="after")
    def _cluster_fits(self):
        if self.cluster is None:
            if any(e.do == "server_down" for e in self.timeline):
                raise ValueError("server_down needs cluster (a server to lose)")
            return self
        refused = {"plant.peer": self.plant.peer is not None, "topology.external_switches": bool(self.topology.external_switches),
                   "links": bool(self.links), "impairable": self.impairable != "listed",
                   "impair actions": any(e.do in ("impair", "clear_impairments") for e in self.timeline),
                   f"switch_ports: {self.switch_ports}": self.switch_ports != "system",
                   f"switch_links: {self.switch_links}": self.switch_links != "veth",
                   "switch_revalidation_ms": self.switch_revalidation_ms is not None}
        if on := [k for k, v in refused.items() if v]:
            raise ValueError(f"a run across servers (cluster) does not take {', '.join(on)} yet: those act on this "
                             f"machine's switches, hosts or interfaces only")
        return self

    def turbines_named(self) -> list[str]:
        names = []
        for event in self.timeline:
            wt = getattr(event, "wt", None)
            if wt and wt not in names:
                names.append(wt)
        return names
