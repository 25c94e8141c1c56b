"""Where a key of a YAML file is: the 1-based line of a key path in the file's node tree.

The same walk as the scenario loader's (``scenarios.loader._line_of``), kept here because sdvisc is
the ground floor and imports nothing above it: :func:`sdvisc.config.load_config` uses it to put the
line beside every problem of a YAML configuration.
"""

from __future__ import annotations

import yaml


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
