"""Topologies by name: the built-in ones (:data:`topologies.topos`, the only list of their names)
and those of a custom file, as Mininet's ``mn --custom FILE.py`` takes them: a Python file that
exports ``topos = {name: TopoClass}``.

A custom topology may not take a built-in name (it would hide the testbed's own without a word).
"""

from __future__ import annotations

import runpy
from functools import lru_cache
from pathlib import Path

from mininet.topo import Topo


class TopologyNotFound(ValueError):
    """An unknown topology name, or a custom file that cannot be read or defines no topology."""


class CustomFileError(TopologyNotFound):
    """A custom file that cannot be read, fails, or defines no (usable) topology."""


def load_custom(path: str | Path) -> dict[str, type[Topo]]:
    """The ``topos`` of the file ``path`` (executed once per version of the file)."""
    path = Path(path)
    try:
        stamp = path.stat().st_mtime_ns
    except OSError as exc:
        raise CustomFileError(f"custom topology file {path}: {exc.strerror}") from exc
    return dict(_load(str(path.resolve()), stamp))


@lru_cache(maxsize=16)
def _load(path: str, _stamp: int) -> dict[str, type[Topo]]:
    try:
        namespace = runpy.run_path(path, run_name="sdvisc_custom_topology")
    except Exception as exc:  # noqa: BLE001 - whatever the file raises is the user's to see
        raise CustomFileError(f"custom topology file {path} failed: {type(exc).__name__}: {exc}") from exc
    found = namespace.get("topos")
    if not isinstance(found, dict) or not found:
        raise CustomFileError(f"custom topology file {path} defines no topology: it must export "
                               f"topos = {{'name': TopoClass}} (as for mn --custom)")
    wrong = [name for name, cls in found.items() if not (isinstance(cls, type) and issubclass(cls, Topo))]
    if wrong:
        raise CustomFileError(f"custom topology file {path}: topos[{wrong[0]!r}] is not a Mininet Topo class")
    return found


def known_topologies(custom: str | Path | None = None) -> dict[str, type[Topo]]:
    """The built-in topologies and, with ``custom``, that file's."""
    from topologies import topos

    if custom is None:
        return dict(topos)
    extra = load_custom(custom)
    hidden = sorted(set(extra) & set(topos))
    if hidden:
        raise CustomFileError(f"custom topology file {custom}: {', '.join(hidden)} would hide the built-in "
                               f"topolog{'ies' if len(hidden) > 1 else 'y'} of that name: rename it")
    return {**topos, **extra}


def topology_class(name: str, custom: str | Path | None = None) -> type[Topo]:
    """The class of topology ``name``; :class:`TopologyNotFound` names the known ones."""
    known = known_topologies(custom)
    if name not in known:
        where = f" (built in, or in {custom})" if custom is not None else " (or give topology.custom: FILE.py)"
        raise TopologyNotFound(f"unknown topology {name!r}: known are {', '.join(known)}{where}")
    return known[name]
