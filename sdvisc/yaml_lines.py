"""YAML files whose problems name their lines: :func:`parse` (the data and its node tree, or one error
naming the line of a syntax error) and :func:`line_of` (the 1-based line of a key path in the node
tree). Used by :func:`sdvisc.config.load_config` (a process's configuration) and
:func:`scenarios.loader.load_scenario` (a scenario), so both put the line beside every problem.
"""

from __future__ import annotations

import yaml


def parse(text: str, path, error: type[Exception]) -> tuple[yaml.Node | None, object]:
    """(node tree, data) of the YAML ``text`` of file ``path``; invalid YAML raises ``error`` with
    ``path:line: not valid YAML: problem``."""
    try:
        return yaml.compose(text), yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f":{mark.line + 1}" if mark else ""
        raise error(f"{path}{where}: not valid YAML: {getattr(exc, 'problem', None) or exc}") from exc


def line_of(node: yaml.Node | None, path: tuple) -> int | None:
    """1-based line of the YAML node at ``path`` (a key of a mapping: the key's line; an index of a
    sequence: the item's), else of the deepest ancestor that exists; None without a node tree."""
    line = node.start_mark.line + 1 if node is not None else None
    for key in path:
        if isinstance(node, yaml.MappingNode):
            for k, v in node.value:
                if isinstance(k, yaml.ScalarNode) and k.value == str(key):
                    node, line = v, k.start_mark.line + 1
                    break
            else:
                return line
        elif isinstance(node, yaml.SequenceNode) and isinstance(key, int) and 0 <= key < len(node.value):
            node = node.value[key]
            line = node.start_mark.line + 1
        else:
            return line
    return line
