"""Scene files: YAML text -> raw data -> --set overrides -> a validated Scene.

Part of the scene module (:mod:`solver.scene` re-exports every name).
"""
from __future__ import annotations

import re
from pathlib import Path

import yaml

from solver.errors import SceneError
from solver.scene.schema import parse
from solver.scene.sections import Scene

def apply_override(raw: dict, assignment: str) -> None:
    """Apply ``key.path=value`` to raw scene data.  List items are addressed by
    index or, for lists of named mappings (partitions, probes), by name."""
    if "=" not in assignment:
        raise SceneError(f"--set {assignment}: expected key.path=value")
    path, text = assignment.split("=", 1)
    value = yaml_load(text) if text.strip() else None
    parts = path.split(".")
    node = raw
    for depth, part in enumerate(parts):
        last = depth == len(parts) - 1
        where = ".".join(parts[:depth + 1])
        if isinstance(node, list):
            idx = _list_index(node, part, where)
            if last:
                node[idx] = value
                return
            node = node[idx]
        elif isinstance(node, dict):
            if last:
                node[part] = value
                return
            if part not in node or node[part] is None:
                node[part] = {}
            node = node[part]
        else:
            raise SceneError(f"--set {path}: '{'.'.join(parts[:depth])}' is not a section")


def _list_index(items: list, part: str, where: str) -> int:
    if part.lstrip("-").isdigit():
        idx = int(part)
        if -len(items) <= idx < len(items):
            return idx
        raise SceneError(f"--set {where}: index out of range ({len(items)} items)")
    for idx, item in enumerate(items):
        if isinstance(item, dict) and item.get("name") == part:
            return idx
    raise SceneError(f"--set {where}: no item named {part!r}")


class _Loader(yaml.SafeLoader):
    """SafeLoader that also reads YAML 1.2 floats such as ``1e-6`` as numbers."""


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
                |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
                |\.[0-9_]+(?:[eE][-+]?[0-9]+)?
                |[-+]?\.(?:inf|Inf|INF)
                |\.(?:nan|NaN|NAN))$""", re.X),
    list("-+0123456789."))


def yaml_load(text: str):
    return yaml.load(text, Loader=_Loader)


def load_raw(path: str | Path) -> dict:
    p = Path(path)
    if not p.is_file():
        raise SceneError(f"{path}: scene file not found")
    try:
        raw = yaml_load(p.read_text())
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f" line {mark.line + 1}" if mark else ""
        raise SceneError(f"{path}:{where} not valid YAML ({getattr(e, 'problem', e)})") from None
    if not isinstance(raw, dict):
        raise SceneError(f"{path}: a scene is a YAML mapping")
    return raw


def from_dict(raw: dict) -> Scene:
    """Parse and validate ``raw``, then bind it to its model data (mesh groups and
    probe points resolved to node ids; see :mod:`solver.model.binding`)."""
    from solver.model.binding import bind
    return bind(parse(Scene, raw))


def load(path: str | Path, overrides=()) -> Scene:
    """Read, override and validate a scene file.  Errors name the file and key."""
    raw = load_raw(path)
    for assignment in overrides:
        apply_override(raw, assignment)
    try:
        return from_dict(raw)
    except SceneError as e:
        raise SceneError(f"{path}: {e}") from None
