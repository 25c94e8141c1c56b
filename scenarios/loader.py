"""Load a scenario YAML file and check it, with errors that name the file, line and key path."""

from __future__ import annotations

from pathlib import Path

import yaml
from pydantic import ValidationError

from scenarios.schema import Scenario


class ScenarioError(ValueError):
    """A scenario that cannot be run; the message names file, line, key path and expectation."""


def _line_of(node, path: tuple) -> int | None:
    """1-based line of the YAML node at ``path`` (deepest existing ancestor if missing)."""
    line = node.start_mark.line + 1 if node is not None else None
    for key in path:
        if isinstance(node, yaml.MappingNode):
            for k, v in node.value:
                if k.value == str(key):
                    node, line = v, k.start_mark.line + 1
                    break
            else:
                return line
        elif isinstance(node, yaml.SequenceNode) and isinstance(key, int) and key < len(node.value):
            node = node.value[key]
            line = node.start_mark.line + 1
        else:
            return line
    return line


def _clean_loc(loc: tuple) -> tuple:
    """Drop pydantic's union-tag entries (e.g. ``'visc_on'``) that are not keys of the file."""
    out = []
    for i, part in enumerate(loc):
        if i > 0 and out and out[0] == "timeline" and len(out) == 2 and isinstance(part, str) and part in (
                "visc_on", "visc_off", "set_params", "link_down", "link_up", "path_link_down", "restore_links", "kill",
                "set", "load_step", "fault", "scr"):
            continue
        out.append(part)
    return tuple(out)


def load_scenario(path: str | Path) -> Scenario:
    """Parse and validate ``path``; raise :class:`ScenarioError` on any problem."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot read: {exc.strerror}") from exc
    try:
        root = yaml.compose(text)
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f":{mark.line + 1}" if mark else ""
        raise ScenarioError(f"{path}{where}: not valid YAML: {getattr(exc, 'problem', exc)}") from exc
    if not isinstance(data, dict):
        raise ScenarioError(f"{path}:1: expected a mapping of scenario keys at the top level")
    try:
        scenario = Scenario.model_validate(data)
    except ValidationError as exc:
        lines = []
        for err in exc.errors():
            loc = _clean_loc(tuple(err["loc"]))
            key = ".".join(str(p) for p in loc) or "(top level)"
            line = _line_of(root, loc)
            msg = err["msg"]
            if err["type"] == "extra_forbidden":
                msg = "unknown key (not allowed here)"
            lines.append(f"{path}:{line}: {key}: {msg}")
        raise ScenarioError("\n".join(lines)) from exc
    _check_names(path, root, scenario)
    return scenario


def _check_names(path: Path, root, scenario: Scenario) -> None:
    """Turbines, hosts and links named in the timeline must exist in the chosen topology."""
    from topologies import topos
    from topologies.base import describe

    desc = describe(topos[scenario.topology.name](**scenario.topology.params()))
    hosts = desc["hosts"]
    links = {frozenset((lk["a"], lk["b"])) for lk in desc["links"]}
    switches = set(desc["switches"])
    problems = []
    for i, event in enumerate(scenario.timeline):
        wt = getattr(event, "wt", None)
        if wt is not None and wt not in hosts:
            problems.append((("timeline", i, "wt"),
                             f"turbine {wt!r} is not in topology {scenario.topology.name} "
                             f"({scenario.topology.clusters}x{scenario.topology.turbines})"))
        if event.do in ("link_down", "link_up"):
            ends = {event.a, event.b}
            if not ends <= switches | set(hosts) or (ends <= switches and frozenset(ends) not in links):
                problems.append((("timeline", i), f"no link {event.a}-{event.b} in topology {scenario.topology.name}"))
        if event.do == "kill" and event.host not in hosts:
            problems.append((("timeline", i, "host"), f"no host {event.host!r}"))
    for name in list(scenario.sdn.visc_disabled) + list(scenario.plant.record or []):
        if name not in hosts:
            problems.append((("sdn",), f"turbine {name!r} is not in the topology"))
    if problems:
        raise ScenarioError("\n".join(
            f"{path}:{_line_of(root, loc)}: {'.'.join(str(p) for p in loc)}: {msg}" for loc, msg in problems))
