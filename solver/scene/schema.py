"""Typed, validated scene objects from plain YAML data.

A scene section is a frozen dataclass whose fields carry their documentation
and constraints in ``metadata``.  :func:`parse` turns a raw mapping into such
an object, refusing unknown keys, wrong types and values out of range with a
:class:`~solver.errors.SceneError` naming the key path.  :func:`describe`
lists every key with its type, default and documentation, so the same source
drives validation, ``python -m solver keys`` and docs/scene.md.
"""
from __future__ import annotations

import dataclasses
import difflib
import math
import types
import typing
from typing import Any, Literal

from solver.errors import SceneError

MISSING = dataclasses.MISSING


def key(doc: str, default: Any = MISSING, *, positive: bool = False,
        nonnegative: bool = False, parse=None, choices_doc=None, variants=()):
    """A documented scene key; ``parse(value, path)`` overrides type conversion;
    ``variants`` lists the sections a ``parse`` hook dispatches to (for docs).
    ``doc`` and ``choices_doc`` may be functions returning the text."""
    meta = {"doc": doc, "positive": positive, "nonnegative": nonnegative, "parse": parse,
            "variants": variants}
    if choices_doc:
        meta["type_doc"] = choices_doc
    if default is MISSING:
        return dataclasses.field(metadata=meta)
    if isinstance(default, (list, dict)):
        return dataclasses.field(default_factory=lambda: type(default)(default), metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


def tagged(tag: str, variants: dict):
    """A ``parse`` hook for a mapping whose ``tag`` key picks the section class."""
    def parse_variant(value, path):
        if not isinstance(value, dict):
            fail(path, f"expected a mapping with a {tag} ({', '.join(variants)}), got {shown(value)}")
        if value.get(tag) not in variants:
            fail(f"{path}.{tag}", f"{shown(value.get(tag))} is not one of {', '.join(variants)}")
        return parse(variants[value[tag]], value, path)
    return parse_variant


SHOWN = 200   # characters of a value an error message echoes (the rest: "... (N characters)")


def shown(value, limit: int = SHOWN) -> str:
    """``repr(value)``, clipped to ``limit`` characters with "… (N characters)",
    N the length of the whole repr.  The work is bounded by the value's distinct
    objects, not its expansion: YAML aliases share one list many times over (an
    alias bomb), and a list can hold itself (shown as [...], as repr does)."""
    total = _repr_length(value, {}, set())
    if total <= limit:
        return repr(value)
    out, size = [], 0
    for chunk in _repr_chunks(value, set(), limit):
        out.append(chunk)
        size += len(chunk)
        if size >= limit:
            break
    return f"{''.join(out)[:limit]}… ({total} characters)"


def _repr_length(value, memo, open_) -> int:
    if not isinstance(value, (list, tuple, dict)):
        return len(repr(value))
    if id(value) in open_:
        return 5                                      # [...] / {...}
    if id(value) in memo:
        return memo[id(value)]
    open_.add(id(value))
    if isinstance(value, dict):
        n = sum(_repr_length(k, memo, open_) + 2 + _repr_length(v, memo, open_)
                for k, v in value.items())
    else:
        n = sum(_repr_length(v, memo, open_) for v in value)
        if isinstance(value, tuple) and len(value) == 1:
            n += 1                                    # (x,)
    open_.discard(id(value))
    n += 2 + 2 * max(len(value) - 1, 0)
    memo[id(value)] = n
    return n


def _repr_chunks(value, open_, limit):
    """repr(value) piece by piece (stopped by the caller after ``limit``)."""
    if not isinstance(value, (list, tuple, dict)):
        yield repr(value[:limit + 1] if isinstance(value, str) else value)
        return
    left, right = ("{", "}") if isinstance(value, dict) else \
        ("[", "]") if isinstance(value, list) else ("(", ")")
    if id(value) in open_:
        yield f"{left}...{right}"
        return
    open_.add(id(value))
    yield left
    pairs = value.items() if isinstance(value, dict) else ((None, v) for v in value)
    for n, (k, v) in enumerate(pairs):
        if n:
            yield ", "
        if isinstance(value, dict):
            yield from _repr_chunks(k, open_, limit)
            yield ": "
        yield from _repr_chunks(v, open_, limit)
    open_.discard(id(value))
    yield right


def fail(path: str, message: str):
    raise SceneError(f"{path}: {message}" if path else message)


def _join(path: str, name) -> str:
    if len(str(name)) > SHOWN:                       # an unknown key of a megabyte
        name = shown(name)
    if isinstance(name, int):
        return f"{path}[{name}]"
    return f"{path}.{name}" if path else str(name)


def _hints(cls) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def parse(cls, raw: Any, path: str = ""):
    """Build dataclass ``cls`` from ``raw``, validating every key."""
    if raw is None:
        raw = {}
    if not isinstance(raw, dict):
        fail(path, f"expected a mapping, got {_kind(raw)} {shown(raw)}")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    for name in raw:
        if name not in fields:
            close = difflib.get_close_matches(str(name), list(fields), n=1)
            hint = f" (did you mean '{close[0]}'?)" if close else f" (known keys: {', '.join(fields)})"
            fail(_join(path, name), f"unknown key{hint}")
    hints = _hints(cls)
    values = {}
    for name, f in fields.items():
        sub = _join(path, name)
        if name not in raw:
            if f.default is MISSING and f.default_factory is MISSING:
                fail(sub, "missing required key")
            continue
        values[name] = convert(hints[name], raw[name], sub, f.metadata)
    obj = cls(**values)
    check = getattr(obj, "validate", None)
    if check is not None:
        check(path)
    return obj


def _kind(value) -> str:
    return {bool: "a boolean", int: "an integer", float: "a number", str: "a string",
            list: "a list", dict: "a mapping", type(None): "nothing"}.get(type(value), type(value).__name__)


def convert(tp, value, path: str, meta=None):
    """Convert ``value`` to annotation ``tp`` (float, int, str, bool, Literal,
    tuple[...], dict[...], Optional, nested dataclass)."""
    meta = meta or {}
    if meta.get("parse") is not None:
        return meta["parse"](value, path)
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        inner = [a for a in args if a is not type(None)]
        sections = [a for a in inner if dataclasses.is_dataclass(a)]
        if isinstance(value, dict) and len(sections) > 1:
            kinds = {typing.get_args(_hints(a)["kind"])[0]: a for a in sections}
            if value.get("kind") not in kinds:
                fail(f"{path}.kind", f"{shown(value.get('kind'))} is not one of {', '.join(kinds)}")
            return convert(kinds[value["kind"]], value, path, {**meta, "parse": None})
        if len(inner) == 1 or (isinstance(value, dict) and len(sections) == 1):
            return convert(sections[0] if isinstance(value, dict) and sections else inner[0],
                           value, path, {**meta, "parse": None})
        lists = [a for a in inner if typing.get_origin(a) is tuple]
        if isinstance(value, list) and len(lists) == 1:     # a list: its own errors, not "is not"
            return convert(lists[0], value, path, {**meta, "parse": None})
        for a in inner:
            try:
                return convert(a, value, path, {**meta, "parse": None})
            except SceneError:
                pass
        fail(path, f"{shown(value)} is not {' or '.join(type_name(a) for a in inner)}")
    if origin is Literal:
        if value not in args:
            fail(path, f"{shown(value)} is not one of {', '.join(map(str, args))}")
        return value
    if origin is tuple:
        if not isinstance(value, list):
            fail(path, f"expected a list, got {_kind(value)} {shown(value)}")
        item = args[0]
        return tuple(convert(item, v, _join(path, i), {k: v2 for k, v2 in meta.items() if k != "parse"})
                     for i, v in enumerate(value))
    if origin is dict:
        if not isinstance(value, dict):
            fail(path, f"expected a mapping, got {_kind(value)} {shown(value)}")
        kt, vt = args
        # integer keys (node ids) also as digits: --set initial.velocity.3=1.0
        return {convert(kt, int(k) if kt is int and isinstance(k, str) and k.isdigit() and len(k) < 19 else k,
                        _join(path, k)): convert(vt, v, _join(path, k), meta)
                for k, v in value.items()}
    if dataclasses.is_dataclass(tp):
        return parse(tp, value, path)
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            fail(path, f"expected a number, got {_kind(value)} {shown(value)}")
        value = float(value)
        if not math.isfinite(value):
            fail(path, f"{value} is not a finite number")
        _sign(value, path, meta)
        return value
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            fail(path, f"expected an integer, got {_kind(value)} {shown(value)}")
        _sign(value, path, meta)
        return value
    if tp is bool:
        if not isinstance(value, bool):
            fail(path, f"expected true or false, got {_kind(value)} {shown(value)}")
        return value
    if tp is str:
        if not isinstance(value, str):
            fail(path, f"expected a string, got {_kind(value)} {shown(value)}")
        return value
    raise TypeError(f"unsupported annotation {tp!r} at {path}")


def _sign(value, path, meta):
    if meta.get("positive") and not value > 0:
        fail(path, f"must be positive, got {value}")
    if meta.get("nonnegative") and not value >= 0:
        fail(path, f"must be non-negative, got {value}")


def type_name(tp) -> str:
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if origin in (typing.Union, types.UnionType):
        return " | ".join(type_name(a) for a in args if a is not type(None))
    if origin is Literal:
        return " | ".join(map(str, args))
    if origin is tuple:
        return f"list of {type_name(args[0])}"
    if origin is dict:
        return f"mapping {type_name(args[0])} -> {type_name(args[1])}"
    if dataclasses.is_dataclass(tp):
        return "mapping"
    return getattr(tp, "__name__", str(tp))


def _text(doc):
    """A key's documentation: a string, or a function giving it (texts generated
    from a registry, e.g. the coupling schemes)."""
    return doc() if callable(doc) else doc


def describe(cls, prefix: str = "") -> list[tuple[str, str, str, str]]:
    """Rows (key path, type, default, doc) for ``cls`` and its nested sections."""
    rows = []
    hints = _hints(cls)
    for f in dataclasses.fields(cls):
        name = f"{prefix}{f.name}"
        tp = hints[f.name]
        tdoc = _text(f.metadata.get("type_doc")) or type_name(tp)
        if f.default is not MISSING:
            default = ("(section defaults)" if dataclasses.is_dataclass(f.default) else
                       repr(f.default) if f.default is not None else "none")
        elif f.default_factory is not MISSING:
            d = f.default_factory()
            default = "{}" if d == {} else "[]" if d in ([], ()) else (
                "(section defaults)" if dataclasses.is_dataclass(d) else repr(d))
        else:
            default = "required"
        rows.append((name, tdoc, default, _text(f.metadata.get("doc", ""))))
        for variant in f.metadata.get("variants", ()):
            tag = "name" if "name" in _hints(variant) else "kind"
            label = typing.get_args(_hints(variant)[tag])[0]
            rows += [(n, t, d, f"({label}) {doc}") for n, t, d, doc in describe(variant, f"{name}.")
                     if n != f"{name}.{tag}"]
        if f.metadata.get("parse") is not None or f.metadata.get("variants"):
            continue                                  # the variants' rows are listed above
        inner = tp
        if typing.get_origin(tp) is tuple:
            inner = typing.get_args(tp)[0]
            sub = f"{name}[]."
        else:
            sub = f"{name}."
        if typing.get_origin(inner) in (typing.Union, types.UnionType):
            for a in typing.get_args(inner):
                if dataclasses.is_dataclass(a):
                    rows += describe(a, sub)
                elif typing.get_origin(a) is tuple and dataclasses.is_dataclass(typing.get_args(a)[0]):
                    rows += describe(typing.get_args(a)[0], f"{name}[].")   # a list, or a word
        elif dataclasses.is_dataclass(inner):
            rows += describe(inner, sub)
    return rows
