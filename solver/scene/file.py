"""Scene files: YAML text -> raw data -> --set overrides -> a validated Scene.

Part of the scene module (:mod:`solver.scene` re-exports every name).
"""
from __future__ import annotations

import os
import re
from pathlib import Path

import yaml

from solver.errors import SceneError
from solver.scene.schema import parse, shown
from solver.scene.sections import Scene

def apply_override(raw: dict, assignment: str) -> None:
    """Apply ``key.path=value`` to raw scene data.  List items are addressed by
    index or, for lists of named mappings (partitions, probes), by name."""
    if "=" not in assignment:
        raise SceneError(f"--set {assignment}: expected key.path=value")
    path, text = assignment.split("=", 1)
    if not path or any(not part for part in path.split(".")):
        raise SceneError(f"--set {assignment}: expected key.path=value")
    try:
        value = yaml_load(text) if text.strip() else None
    except yaml.YAMLError as e:
        raise SceneError(f"--set {path}: the value is not valid YAML ({yaml_problem(e).strip()})") from None
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
            if re.fullmatch(r"[0-9]{1,18}", part) and int(part) in node:
                part = int(part)                # initial.displacement.3: node 3's entry
            if last:
                node[part] = value
                return
            if part not in node or node[part] is None:
                node[part] = {}
            node = node[part]
        else:
            raise SceneError(f"--set {path}: '{'.'.join(parts[:depth])}' is not a section")


def _list_index(items: list, part: str, where: str) -> int:
    if re.fullmatch(r"-?[0-9]{1,18}", part):
        idx = int(part)
        if -len(items) <= idx < len(items):
            return idx
        raise SceneError(f"--set {where}: index {idx} out of range ({_choices(items)})")
    for idx, item in enumerate(items):
        if isinstance(item, dict) and item.get("name") == part:
            return idx
    raise SceneError(f"--set {where}: no item named {shown(part)} ({_choices(items)})")


def _choices(items: list) -> str:
    """What addresses an item of ``items``: its indices and, for named items
    (partitions, probes), its names (the first 20)."""
    if not items:
        return "the list is empty"
    names = [shown(item["name"], 40) for item in items
             if isinstance(item, dict) and isinstance(item.get("name"), str)]
    text = f"{len(items)} item{'s' if len(items) > 1 else ''}: index 0" + \
        (f"-{len(items) - 1}" if len(items) > 1 else "")
    if names:
        more = f", ... ({len(names)} names)" if len(names) > 20 else ""
        text += f" or a name: {', '.join(names[:20])}{more}"
    return text


MAX_ALIASES = 100        # alias uses per document: anchors are for reuse, not expansion bombs
MAX_DEPTH = 32           # nesting of mappings and lists


class _Loader(yaml.SafeLoader):
    """SafeLoader that also reads YAML 1.2 floats such as ``1e-6`` as numbers,
    and refuses duplicate keys, alias expansion and deep nesting."""

    def compose_node(self, parent, index):
        self._depth = getattr(self, "_depth", 0) + 1
        try:
            if self._depth > MAX_DEPTH:
                raise yaml.YAMLError(f"nesting deeper than {MAX_DEPTH} levels")
            if self.check_event(yaml.AliasEvent):
                self._aliases = getattr(self, "_aliases", 0) + 1
                if self._aliases > MAX_ALIASES:
                    raise yaml.YAMLError(f"more than {MAX_ALIASES} alias uses (*name)")
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def construct_mapping(self, node, deep=False):
        seen = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)
            try:
                dup = key in seen
            except TypeError:
                raise yaml.constructor.ConstructorError(
                    None, None, "a mapping key must be a plain value", key_node.start_mark)
            if dup:
                raise yaml.constructor.ConstructorError(
                    None, None, f"duplicate key {shown(key)}", key_node.start_mark)
            seen.add(key)
        return super().construct_mapping(node, deep)


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


def yaml_problem(e: yaml.YAMLError) -> str:
    """' line N: problem' of a YAML error, short (never the document)."""
    mark = getattr(e, "problem_mark", None)
    where = f" line {mark.line + 1}" if mark else ""
    problem = getattr(e, "problem", None) or str(e)
    problem = " ".join(str(problem).split())
    return f"{where} {problem[:200]}"


def load_raw(path: str | Path) -> dict:
    p = Path(path)
    if not p.is_file():
        raise SceneError(f"{path}: scene file not found")
    try:
        raw = yaml_load(p.read_bytes().decode("utf-8"))
    except UnicodeDecodeError as e:
        raise SceneError(f"{path}: not UTF-8 text (byte {e.object[e.start]:#04x} at offset "
                         f"{e.start})") from None
    except yaml.YAMLError as e:
        raise SceneError(f"{path}:{yaml_problem(e)} (not a valid scene YAML)") from None
    if not isinstance(raw, dict):
        raise SceneError(f"{path}: a scene is a YAML mapping")
    return raw


def from_dict(raw: dict) -> Scene:
    """Parse and validate ``raw``: its own keys only.  The checks against the model
    data (mesh groups, probe points to node ids) are the model stage's:
    :func:`solver.model.binding.from_dict` parses and binds."""
    return parse(Scene, raw)


def load(path: str | Path, overrides=()) -> Scene:
    """Read, override and validate a scene file (not bound: see
    :func:`solver.model.binding.load`).  Errors name the file and key."""
    return load_with_text(path, overrides)[0]


# keys holding paths: in a scene file they are relative to the file's directory
PATH_KEYS = (("model", "mesh"), ("model", "file"), ("output", "file"))


def anchor_paths(raw: dict, base: str | Path) -> dict:
    """``raw`` with its relative paths (PATH_KEYS) joined to ``base``, and the
    default output ``results/<name>.h5`` placed there too."""
    for section, key in PATH_KEYS:
        node = raw.get(section)
        if isinstance(node, dict) and isinstance(node.get(key), str) and node[key].strip():
            if not os.path.isabs(node[key]):
                node[key] = os.path.normpath(os.path.join(str(base), node[key]))
    if raw.get("output") is None and isinstance(raw.get("name"), str):
        raw["output"] = {"file": os.path.normpath(os.path.join(str(base), "results",
                                                               f"{raw['name']}.h5"))}
    return raw


def load_with_text(path: str | Path, overrides=(), then=None) -> tuple[Scene, str]:
    """(the scene, the effective scene as YAML: the file with the overrides applied).
    Paths in the file are relative to its directory; paths given in
    ``overrides`` to the working directory.  ``then``: a function of the parsed
    scene whose result is returned (the binding), its errors named by the file too."""
    raw = anchor_paths(load_raw(path), Path(path).parent)
    for assignment in overrides:
        apply_override(raw, assignment)
    try:
        scene = from_dict(raw)
        if then is not None:
            scene = then(scene)
    except SceneError as e:
        raise SceneError(f"{path}: {e}") from None
    return scene, yaml.safe_dump(raw, sort_keys=False)
