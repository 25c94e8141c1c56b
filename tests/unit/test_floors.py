"""The project's structure: packages on floors, no import upward, no import cycles — read from the
code itself (every ``import`` statement, at module level or inside a function, so a lazy import
cannot hide one). docs/architecture.md draws the same floors."""

from __future__ import annotations

import ast
from pathlib import Path

import networkx as nx
import pytest

ROOT = Path(__file__).resolve().parents[2]
FLOORS = {
    "sdvisc": 0,  # the contract: wire format, vocabulary, configuration schema, clock, netns and file helpers
    "owfcc": 1,  # the OWFCC process
    "impairment": 1,  # the link impairment queue and its element process
    "host_tools": 1,  # cleanup, CPU split, capture decoder, hostile-traffic sender
    "sdc_unit": 1,  # the SDC's law, discretisations, controller bank (and its service)
    "topologies": 1,  # Mininet topologies (what the network is)
    "sdn_app": 1,  # the SDN logic (above the vocabulary only) and its os-ken shim
    "plant": 2,  # the plant model (uses the SDC's law for its HD ViSC turbines) and its service
    "scenarios": 3,  # schema, runner, CLI, summary
    "benchmarks": 4,
    "report": 4,  # the paper report (python -m report): runs scenarios as subprocesses; imports two constants of them
}
SERVICES = {"service", "app", "__main__", "element", "fuzz"}  # processes, not models
MODELS = {("sdc_unit", "law"), ("sdc_unit", "params"), ("sdc_unit", "blocks"), ("sdc_unit", "discrete"),
          ("plant", "sim"), ("plant", "turbine"), ("plant", "network"), ("plant", "params"), ("plant", "minimal")}


def modules() -> dict[str, Path]:
    out = {}
    for package in FLOORS:
        base = ROOT / package
        for path in sorted(base.rglob("*.py")):
            rel = path.relative_to(ROOT).with_suffix("")
            parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
            out[".".join(parts)] = path
    return out


def project_imports(path: Path, name: str, known: dict[str, Path]) -> set[str]:
    """Project modules imported anywhere in ``path`` (resolved to the longest known module name)."""
    tree = ast.parse(path.read_text(), filename=str(path))
    found = set()
    for node in ast.walk(tree):
        targets = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # relative import
                pkg = name.split(".")[: -node.level] if not path.name == "__init__.py" else name.split(".")
                base = ".".join(pkg + ([base] if base else []))
            targets = [f"{base}.{a.name}" for a in node.names] + [base]
        for target in targets:
            parts = target.split(".")
            while parts and ".".join(parts) not in known:
                parts.pop()
            if parts and parts[0] in FLOORS:
                found.add(".".join(parts))
    found.discard(name)
    return found


@pytest.fixture(scope="module")
def graph() -> nx.DiGraph:
    known = modules()
    g = nx.DiGraph()
    for name, path in known.items():
        g.add_node(name)
        for target in project_imports(path, name, known):
            g.add_edge(name, target)
    return g


def test_the_walker_sees_the_project(graph):
    assert graph.number_of_nodes() > 40
    assert graph.has_edge("scenarios.runner", "scenarios.summary")
    assert graph.has_edge("sdn_app.logic", "sdn_app.state")


def test_no_package_imports_a_package_above_it(graph):
    upward = [(a, b) for a, b in graph.edges if FLOORS[a.split(".")[0]] < FLOORS[b.split(".")[0]]]
    assert upward == [], f"imports that run up a floor: {upward}"


def test_the_bottom_floor_imports_nothing_of_the_project_but_itself(graph):
    bad = [(a, b) for a, b in graph.edges if a.startswith("sdvisc") and not b.startswith("sdvisc")]
    assert bad == []


def test_the_ground_floor_is_the_contract_only():
    """sdvisc/ is what every package must agree on (wire, layouts, vocabulary, config, clock, small
    shared utilities): no module of it is a process (no ``__main__``), starts one or handles signals;
    processes and host tools live a floor up, named for what they are. (Reading a service's
    ``--config`` is configuration: :func:`sdvisc.config.service_config`.)"""
    found = {}
    for path in sorted((ROOT / "sdvisc").glob("*.py")):
        tree = ast.parse(path.read_text())
        names = {a.name for node in ast.walk(tree) if isinstance(node, ast.Import) for a in node.names}
        names |= {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom) and node.module}
        mains = [node for node in ast.walk(tree) if isinstance(node, ast.Compare)
                 and any(isinstance(c, ast.Constant) and c.value == "__main__" for c in node.comparators)]
        bad = sorted(names & {"subprocess", "signal", "multiprocessing"}) + (["__main__"] if mains else [])
        if bad:
            found[path.name] = bad
    assert found == {}, f"processes or process control on the ground floor: {found}"


def test_the_sdn_logic_stands_on_the_vocabulary_only(graph):
    bad = [(a, b) for a, b in graph.edges if a.startswith("sdn_app") and b.split(".")[0] not in ("sdn_app", "sdvisc")]
    assert bad == []


def test_models_never_import_a_service(graph):
    bad = [(a, b) for a, b in graph.edges if tuple(a.split(".")[:2]) in MODELS and b.split(".")[-1] in SERVICES]
    assert bad == []


def test_no_import_cycles(graph):
    cycles = [sorted(c) for c in nx.strongly_connected_components(graph) if len(c) > 1]
    assert cycles == [], f"modules that import each other (directly or around a circle): {cycles}"
