"""Load a scenario YAML file and check it, with errors that name the file, line and key path.

Every problem of a file is reported at once: pydantic's field errors, and the checks across
sections (timeline times within ``duration_s``; turbines, hosts and links in the topology; ``set``
parameters and plant actions the ``plant.model`` class can apply, plant/settable.py) made on
whatever validated.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from pydantic import TypeAdapter, ValidationError

from plant.emt import FARM_VISC_HOSTS
from plant.settable import ACTIONS as PLANT_ACTIONS
from plant.settable import model_class, relative_params, settable_params, supported_actions
from scenarios.cluster_spec import ClusterSpec, cluster_problems
from scenarios.external_spec import PeerSpec, external_problems
from scenarios.schema import EVENT_KINDS, Event, Scenario, TopologySpec
from sdvisc.yaml_lines import line_of
from sdvisc.yaml_lines import parse as parse_yaml

_EVENT = TypeAdapter(Event)


class ScenarioError(ValueError):
    """A scenario that cannot be run; the message names file, line, key path and expectation."""


def _clean_loc(loc: tuple) -> tuple:
    """Drop pydantic's union-tag entries (e.g. ``'visc_on'``) that are not keys of the file."""
    out = []
    for part in loc:
        if len(out) == 2 and out[0] == "timeline" and isinstance(part, str) and part in EVENT_KINDS:
            continue
        out.append(part)
    return tuple(out)


def _message(err: dict, data: dict, scenario_dir: Path) -> str:
    if err["type"] == "extra_forbidden" and len(err["loc"]) == 2 and err["loc"][0] == "topology":
        return _not_an_option(data["topology"], scenario_dir)
    if err["type"] == "extra_forbidden":
        return "unknown key (not allowed here)"
    if err["type"] == "finite_number":
        return f"must be a finite number, not {err['input']!r}"
    return err["msg"]


def _not_an_option(section: dict, scenario_dir: Path) -> str:
    """The message for an unknown key of the topology section: the topology's options."""
    from topologies.custom import TopologyNotFound, topology_class
    from topologies.options import described_options

    name, custom = section.get("name", "paper"), section.get("custom")
    if not isinstance(name, str) or not isinstance(custom, str | None):
        return "not an option of the topology"
    try:
        cls = topology_class(name, None if custom is None else scenario_dir / custom)
        return f"not an option of topology {name} (its options: {described_options(cls)})"
    except TopologyNotFound:  # a custom one: named in its own error if unknown
        return f"not an option of topology {name}"


@dataclass(frozen=True)
class Override:
    """A command-line option that replaces one key of the scenario (``--time-scale auto`` sets
    ``time_scale``): it goes through the same schema and cross-section checks as the file's key,
    and a problem with it names the option rather than a line of the file."""

    option: str
    text: str  # as the user typed it
    key: tuple
    value: object

    def apply(self, data: dict) -> None:
        node = data
        for part in self.key[:-1]:
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                return  # the file's own value is no mapping: the file's error says so
        node[self.key[-1]] = self.value

    def concerns(self, loc: tuple, msg: str) -> bool:
        """A problem at ``loc`` is this option's: at its key, or a check across keys that names it."""
        return loc[:len(self.key)] == self.key or (not loc and ".".join(map(str, self.key)) in msg)


def load_scenario(path: str | Path, overrides: list[Override] | tuple = ()) -> Scenario:
    """Parse and validate ``path`` with the command line's ``overrides`` put in place of the keys
    they replace; raise :class:`ScenarioError` naming every problem: file, line and key for the
    file's, the option for an override's."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot read: {exc.strerror}") from exc
    root, data = parse_yaml(text, path, ScenarioError)
    if not isinstance(data, dict):
        raise ScenarioError(f"{path}:1: expected a mapping of scenario keys at the top level")
    for override in overrides:
        override.apply(data)
    problems: list[tuple[tuple, str]] = []
    context = {"scenario_dir": path.parent}  # (topology.custom is relative to the file)
    try:
        scenario = Scenario.model_validate(data, context=context)
    except ValidationError as exc:
        scenario = None
        problems = [(_clean_loc(tuple(err["loc"])), _message(err, data, path.parent)) for err in exc.errors()]
    parts = _Parts.of_scenario(scenario) if scenario is not None else \
        _Parts.of_partial(data, {loc for loc, _ in problems}, context)
    problems += parts.problems()
    if problems:
        raise ScenarioError("\n".join(_report(path, root, problems, overrides)))
    return scenario


def _report(path: Path, root, problems: list[tuple[tuple, str]], overrides) -> list[str]:
    """One line per problem: ``file:line: key: message``, or ``--option value: key: message`` for a
    problem with an override (the options' lines first)."""
    options, lines = [], []
    for loc, msg in problems:
        key = ".".join(str(p) for p in loc) or "(top level)"
        by = next((o for o in overrides if o.concerns(loc, msg)), None)
        if by is not None:
            options.append(f"{by.option} {by.text}: {'.'.join(map(str, by.key))}: {msg}")
        else:
            durations = [o for o in overrides if o.key == ("duration_s",)]
            note = f" (duration_s from {durations[0].option} {durations[0].text})" if durations and "duration_s" in msg else ""
            lines.append((line_of(root, loc), f"{path}:{line_of(root, loc)}: {key}: {msg}{note}"))
    lines.sort(key=lambda item: item[0] or 0)
    return options + [text for _, text in lines]


@dataclass
class _Parts:
    """What the cross-section checks need: the parts of the file that validated on their own."""

    topology: TopologySpec
    duration_s: float | None  # None: duration_s itself is invalid, or open-ended (null)
    model: str | None  # None: plant.model is invalid
    events: list[tuple[int, object]]  # (index in the timeline, validated event)
    turbines: list[tuple[tuple, str]]  # (key path, name) of sdn.visc_disabled and plant.record
    links: list[tuple[tuple, str, str]]  # (key path, a, b) of links and impairable entries
    peer: PeerSpec | None = None  # plant.peer (an external plant)
    cluster: ClusterSpec | None = None  # cluster (the run across servers)

    @classmethod
    def of_scenario(cls, sc: Scenario) -> _Parts:
        turbines = [(("sdn", "visc_disabled", j), n) for j, n in enumerate(sc.sdn.visc_disabled)]
        turbines += [(("sdn", "managers", j, "turbines", k), n) for j, m in enumerate(sc.sdn.managers)
                     for k, n in enumerate(m.turbines or [])]
        turbines += [(("plant", "record", j), n) for j, n in enumerate(sc.plant.record or [])]
        if sc.plant.batteries is not None:
            turbines += [(("plant", "batteries", "turbines", j), n) for j, n in enumerate(sc.plant.batteries.turbines)]
        turbines += [(("plant", "p_star", n), n) for n in sc.plant.p_star or {}]
        links = [(("links", j), lk.a, lk.b) for j, lk in enumerate(sc.links)]
        if isinstance(sc.impairable, list):
            links += [(("impairable", j), lk.a, lk.b) for j, lk in enumerate(sc.impairable)]
        return cls(sc.topology, sc.duration_s, sc.plant.model, list(enumerate(sc.timeline)), turbines, links,
                   sc.plant.peer, sc.cluster)

    @classmethod
    def of_partial(cls, data: dict, bad: set[tuple], context: dict) -> _Parts:
        """From a file that failed validation: each section, field and timeline entry that has no
        error of its own (the default topology if ``topology`` is bad)."""
        def ok(*path) -> bool:
            return not any(loc[:len(path)] == path for loc in bad)

        topology = TopologySpec.model_validate(data["topology"], context=context) \
            if "topology" in data and ok("topology") else TopologySpec()
        duration = float(data["duration_s"]) if data.get("duration_s") is not None and ok("duration_s") else None
        plant = data.get("plant", {})
        model = plant.get("model", "minimal") if isinstance(plant, dict) and ok("plant", "model") else None
        events = []
        if isinstance(data.get("timeline"), list):
            for i, entry in enumerate(data["timeline"]):
                try:
                    events.append((i, _EVENT.validate_python(entry)))
                except ValidationError:
                    pass  # reported already
        turbines = []
        for section, key in (("sdn", "visc_disabled"), ("plant", "record")):
            names = data.get(section, {}).get(key) if isinstance(data.get(section), dict) else None
            if isinstance(names, list):
                turbines += [((section, key, j), n) for j, n in enumerate(names)
                             if isinstance(n, str) and ok(section, key, j)]
        plant = data.get("plant") if isinstance(data.get("plant"), dict) else {}
        batteries = plant.get("batteries") if isinstance(plant.get("batteries"), dict) else {}
        if isinstance(batteries.get("turbines"), list) and ok("plant", "batteries"):
            turbines += [(("plant", "batteries", "turbines", j), n) for j, n in enumerate(batteries["turbines"])]
        if isinstance(plant.get("p_star"), dict) and ok("plant", "p_star"):
            turbines += [(("plant", "p_star", n), n) for n in plant["p_star"]]
        links = []
        for section in ("links", "impairable"):
            entries = data.get(section)
            if isinstance(entries, list):
                links += [((section, j), e["a"], e["b"]) for j, e in enumerate(entries)
                          if isinstance(e, dict) and isinstance(e.get("a"), str) and isinstance(e.get("b"), str)
                          and ok(section, j, "a") and ok(section, j, "b")]
        try:
            peer = PeerSpec.model_validate(plant["peer"]) if isinstance(plant.get("peer"), dict) else None
        except ValidationError:
            peer = None  # reported already
        try:
            cluster = ClusterSpec.model_validate(data["cluster"]) if isinstance(data.get("cluster"), dict) else None
        except ValidationError:
            cluster = None  # reported already
        return cls(topology, duration, model, events, turbines, links, peer, cluster)

    def problems(self) -> list[tuple[tuple, str]]:
        out = []
        if self.duration_s is not None:
            out += [(("timeline", i, "t"), f"t={e.t} s is after duration_s={self.duration_s}")
                    for i, e in self.events if e.t > self.duration_s]
        out += self._name_problems()
        if self.model is not None:
            out += self._plant_problems()
        return out

    def _name_problems(self) -> list[tuple[tuple, str]]:
        """Turbines, hosts and links named in the timeline must exist in the chosen topology."""
        from topologies.base import describe

        topo = self.topology
        try:
            desc = describe(topo.topo_class()(**topo.params()))
        except Exception as exc:  # noqa: BLE001 - a custom topology's build is the user's code: say what it raised
            return [(("topology",), f"topology {topo.label()} cannot be built: {type(exc).__name__}: {exc}")]
        problems = external_problems(desc, topo.external_switches, self.peer)
        if self.cluster is not None:
            problems += cluster_problems(desc, self.cluster, self.events)
        if self.peer is not None:  # the peer's turbines are hosts of the run (the card's), whether in the topology or not
            desc["hosts"].update({name: {"role": "turbine"} for name in self.peer.turbines})
        hosts = desc["hosts"]
        links = {frozenset((lk["a"], lk["b"])) for lk in desc["links"]}
        switches = set(desc["switches"])
        for i, event in self.events:
            wt = getattr(event, "wt", None)
            if wt is not None and wt not in hosts:
                problems.append((("timeline", i, "wt"),
                                 f"turbine {wt!r} is not in topology {topo.label()}"))
            if event.do in ("link_down", "link_up"):
                ends = {event.a, event.b}
                if not ends <= switches | set(hosts) or (ends <= switches and frozenset(ends) not in links):
                    problems.append((("timeline", i), f"no link {event.a}-{event.b} in topology {topo.name}"))
            if event.do in ("impair", "clear_impairments") and event.a is not None \
                    and frozenset((event.a, event.b)) not in links:
                problems.append((("timeline", i), f"no switch-to-switch link {event.a}-{event.b} in topology {topo.name}"))
            if event.do == "spoof_ak" and event.victim not in hosts:
                problems.append((("timeline", i, "victim"), f"turbine {event.victim!r} is not in topology {topo.name}"))
            if event.do in ("kill", "fuzz", "spoof_ak") and self.peer is not None and event.host in self.peer.turbines:
                problems.append((("timeline", i, "host"), f"{event.host} is a turbine of the external peer: the run "
                                                           f"has no host of it to act from"))
            if event.do in ("kill", "fuzz", "spoof_ak") and event.host not in hosts:
                problems.append((("timeline", i, "host"), f"no host {event.host!r}"))
            if event.do == "fuzz":
                problems += [(("timeline", i, "targets", j), f"no host {name!r} (or 'controller')")
                             for j, name in enumerate(event.targets) if name not in hosts and name != "controller"]
        seen: dict[frozenset, tuple] = {}
        for loc, a, b in self.links:
            pair = frozenset((a, b))
            if pair not in links:
                problems.append((loc, f"no switch-to-switch link {a}-{b} in topology {topo.name} "
                                      f"(links: {', '.join(sorted(lk['a'] + '-' + lk['b'] for lk in desc['links']))})"))
            elif loc[0] == "links" and pair in seen:
                problems.append((loc, f"link {a}-{b} is listed twice (also at links.{seen[pair][1]})"))
            if loc[0] == "links":
                seen.setdefault(pair, loc)
        for loc, name in self.turbines:
            if name not in hosts:
                problems.append((loc, f"turbine {name!r} is not in topology {topo.label()}"))
        return problems

    def _plant_problems(self) -> list[tuple[tuple, str]]:
        """``set`` parameters and plant actions must be ones the ``plant.model`` class can apply."""
        if self.model == "external":  # no plant process: nothing of the testbed's can reach into the peer's model
            return [(("timeline", i, "do"), f"{event.do} acts on the plant model; an external plant (plant.peer) "
                                            f"takes no commands from the testbed")
                    for i, event in self.events if event.do in PLANT_ACTIONS or event.do == "set"]
        cls = model_class(self.model)
        settable = settable_params(cls)
        relative = relative_params(cls)
        supported = supported_actions(cls)
        problems = []
        if self.topology.option("onshore_units") and self.model not in ("full", "emt"):
            problems.append((("topology", "onshore_units"), f"onshore units are converters of the full farm "
                             f"model (PlantParams.onshore_units) or the EMT arrangement's SDViSC: needs plant.model: "
                             f"full or emt, not {self.model}"))
        onshore = self.topology.option("onshore_units")
        farm_visc = FARM_VISC_HOSTS
        off_farm = sorted({e.wt for _, e in self.events if e.do == "visc_on" and e.wt not in farm_visc})
        if self.model == "emt" and (onshore not in (0, None, 1) or (not onshore and off_farm)):
            problems.append((("plant", "model"), "plant.model emt is the paper's comparison arrangement (topology."
                             "onshore_units: 1, its SDViSC host wt6_1) or, without onshore units, F8's farm "
                             f"arrangement whose SDViSCs are {', '.join(farm_visc)}"
                             + (f": visc_on {', '.join(off_farm)} has no converter there" if off_farm else "")))
        for i, event in self.events:
            if event.do == "set" and event.param not in settable:
                problems.append((("timeline", i, "param"),
                                 f"plant model {self.model} has no settable parameter {event.param!r} "
                                 f"(settable: {', '.join(settable) or 'none'})"))
            elif event.do == "set" and event.delta is not None and event.param not in relative:
                problems.append((("timeline", i, "delta"),
                                 f"plant model {self.model} cannot change {event.param!r} by a delta (it cannot "
                                 f"read it back); give value, or a delta of: {', '.join(relative) or 'none'}"))
            elif event.do in PLANT_ACTIONS and event.do not in supported:
                problems.append((("timeline", i, "do"), f"plant model {self.model} cannot apply {event.do}"))
        return problems
