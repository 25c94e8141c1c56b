"""Configuration files of the testbed's processes: read (YAML or JSON), validated against a model of
:mod:`sdvisc.config`, written; one error type, :class:`ConfigError`, naming the file, each key (and
its line in YAML) and what was expected — every problem of a file at once. Re-exported by
:mod:`sdvisc.config`, where the models are.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TypeVar

import yaml
from pydantic import BaseModel, ValidationError

from sdvisc.yaml_lines import line_of
from sdvisc.yaml_lines import parse as parse_yaml


class ConfigError(ValueError):
    """A process configuration that cannot be used; the message names the file, key and problem."""


C = TypeVar("C", bound=BaseModel)


def _explain(path: str | Path, exc: ValidationError, nodes: yaml.Node | None = None) -> str:
    """One line per problem, ``FILE: key.path: problem``; with the YAML node tree of the file
    (``nodes``) ``FILE:LINE: key.path: problem``, in the order of the lines."""
    lines = []
    for err in exc.errors():
        where = ".".join(str(p) for p in err["loc"]) or "(top level)"
        msg = "unknown key (not allowed here)" if err["type"] == "extra_forbidden" else err["msg"]
        line = line_of(nodes, tuple(err["loc"])) if nodes is not None else None
        lines.append((line or 0, f"{path}{f':{line}' if line else ''}: {where}: {msg}"))
    if nodes is not None:
        lines.sort(key=lambda item: item[0])
    return "\n".join(text for _, text in lines)


def parse_config(model: type[C], data: dict, source: str | Path = "<config>", *, nodes: yaml.Node | None = None) -> C:
    """Validate ``data`` as ``model``; :class:`ConfigError` listing every problem otherwise (with
    the line of each key when ``nodes``, the YAML node tree ``data`` was read from, is given)."""
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(_explain(source, exc, nodes)) from exc


YAML_SUFFIXES = (".yaml", ".yml")
"""A configuration file with one of these suffixes is read as YAML (``yaml.safe_load``), any other as JSON."""


def load_config(model: type[C], path: str | Path) -> C:
    """Read and validate a process configuration file: YAML (:data:`YAML_SUFFIXES`, as a lab writes
    it by hand) or JSON (what :func:`write_config` and the runner write). Every problem of the file
    is reported at once, each with its key path and, in a YAML file, its line."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read config: {exc.strerror or exc}") from exc
    if path.suffix.lower() not in YAML_SUFFIXES:
        try:
            raw = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ConfigError(f"{path}: cannot read JSON config: {exc}") from exc
        return parse_config(model, raw, path)
    nodes, raw = parse_yaml(text, path, ConfigError)
    return parse_config(model, raw, path, nodes=nodes)


def load_config_or_exit(model: type[C], path: str | Path, process: str) -> C:
    """:func:`load_config` at a process's start: a configuration it cannot use ends it with status 2
    and the :class:`ConfigError` on stderr, prefixed with ``process`` (the runner shows the log)."""
    try:
        return load_config(model, path)
    except ConfigError as exc:
        print(f"{process}: {exc}", file=sys.stderr)
        raise SystemExit(2) from None


def service_config(model: type[C], argv: list[str] | None, *, prog: str, process: str, description: str = "") -> C:
    """A service's configuration from its command line (``--config FILE``, as the runner starts every
    service), through :func:`load_config_or_exit`."""
    parser = argparse.ArgumentParser(prog=prog, description=description)
    parser.add_argument("--config", required=True, help=(
        "the configuration: JSON (as the runner writes it) or YAML (.yaml/.yml)"))
    return load_config_or_exit(model, parser.parse_args(argv).config, process)


def write_config(config: BaseModel, path: str | Path) -> Path:
    """Write a validated configuration as JSON (what :func:`load_config` reads back)."""
    path = Path(path)
    path.write_text(config.model_dump_json(indent=1))
    return path
