"""Expressions of position in scene files: ``"-5 * (x < 0.05)"``, ``"1e-3 * sin(pi * y / 0.1)"``.

An expression is checked when the scene is read (:func:`check`: a syntax
error, a name or call that is not allowed is refused naming the key) and
evaluated once per node set (:func:`evaluate`) with numpy arrays for x, y
and z (z is 0 in 2D).  Allowed: numbers, x, y, z, pi, e, + - * / ** %,
comparisons (true is 1, false 0), & | ~ on comparisons, and the functions
in :data:`FUNCTIONS`.  Nothing else of Python is reachable: the tree is
walked node by node, never handed to ``eval``.
"""
from __future__ import annotations

import ast
import math
import operator

import numpy as np

from solver.errors import SceneError

NAMES = ("x", "y", "z")
CONSTANTS = {"pi": math.pi, "e": math.e}
FUNCTIONS = {"sin": np.sin, "cos": np.cos, "tan": np.tan, "exp": np.exp, "log": np.log,
             "sqrt": np.sqrt, "abs": np.abs, "tanh": np.tanh, "where": np.where,
             "minimum": np.minimum, "maximum": np.maximum}
BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
          ast.Div: operator.truediv, ast.Pow: operator.pow, ast.Mod: operator.mod,
          ast.BitAnd: np.logical_and, ast.BitOr: np.logical_or}
UNARY = {ast.USub: operator.neg, ast.UAdd: operator.pos, ast.Invert: np.logical_not}
COMPARE = {ast.Lt: operator.lt, ast.LtE: operator.le, ast.Gt: operator.gt,
           ast.GtE: operator.ge, ast.Eq: operator.eq, ast.NotEq: operator.ne}
ALLOWED = (f"numbers, {', '.join(NAMES)}, {', '.join(CONSTANTS)}, + - * / ** %, comparisons, "
           f"& | ~ and {', '.join(FUNCTIONS)}")


def _tree(text: str, path: str) -> ast.AST:
    try:
        return ast.parse(text.strip(), mode="eval").body
    except SyntaxError as e:
        raise SceneError(f"{path}: {text!r} is not an expression ({e.msg})") from None


def _walk(node, env, path, text):
    """The value of ``node`` with the names of ``env`` (None: check only)."""
    def bad(what):
        raise SceneError(f"{path}: {text!r}: {what} is not allowed (an expression of position "
                         f"uses {ALLOWED})")
    if isinstance(node, ast.Constant):
        if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
            bad(repr(node.value))
        return float(node.value)
    if isinstance(node, ast.Name):
        if node.id in CONSTANTS:
            return CONSTANTS[node.id]
        if node.id not in NAMES:
            bad(f"the name {node.id!r}")
        return None if env is None else env[node.id]
    if isinstance(node, ast.BinOp) and type(node.op) in BINARY:
        a, b = _walk(node.left, env, path, text), _walk(node.right, env, path, text)
        return None if env is None else BINARY[type(node.op)](a, b)
    if isinstance(node, ast.UnaryOp) and type(node.op) in UNARY:
        a = _walk(node.operand, env, path, text)
        return None if env is None else UNARY[type(node.op)](a)
    if isinstance(node, ast.Compare) and len(node.ops) == 1 and type(node.ops[0]) in COMPARE:
        a, b = _walk(node.left, env, path, text), _walk(node.comparators[0], env, path, text)
        return None if env is None else COMPARE[type(node.ops[0])](a, b)
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and not node.keywords:
        f = FUNCTIONS.get(node.func.id)
        if f is None:
            bad(f"the function {node.func.id!r}")
        args = [_walk(a, env, path, text) for a in node.args]
        if node.func.id == "where" and len(args) != 3 or \
                node.func.id in ("minimum", "maximum") and len(args) != 2 or \
                node.func.id not in ("where", "minimum", "maximum") and len(args) != 1:
            raise SceneError(f"{path}: {text!r}: {node.func.id} takes "
                             f"{ {'where': 3, 'minimum': 2, 'maximum': 2}.get(node.func.id, 1)} "
                             "argument(s)")
        return None if env is None else f(*args)
    bad(type(node).__name__ if not isinstance(node, ast.Compare) else "a chained comparison")


def check(text: str, path: str) -> str:
    """``text`` if it is an allowed expression of position, else a SceneError naming ``path``."""
    _walk(_tree(text, path), None, path, text)
    return text


def evaluate(value, points: np.ndarray, path: str) -> np.ndarray:
    """``value`` (a number, or an expression of x, y, z) at ``points`` [n, dim]:
    [n] floats; a non-finite value is refused naming the point."""
    n = len(points)
    if not isinstance(value, str):
        return np.full(n, float(value))
    env = {name: (points[:, i] if i < points.shape[1] else np.zeros(n))
           for i, name in enumerate(NAMES)}
    with np.errstate(all="ignore"):
        out = np.broadcast_to(np.asarray(_walk(_tree(value, path), env, path, value),
                                         dtype=float), (n,)).copy()
    bad = np.flatnonzero(~np.isfinite(out))
    if bad.size:
        raise SceneError(f"{path}: {value!r} is {out[bad[0]]} at {points[bad[0]].tolist()} "
                         f"({bad.size} such nodes)")
    return out
