"""The package's imports run one way, down the stages (docs/dev/stages.md).

An AST scan of every module of ``solver/`` (imports at module level and inside
functions alike) builds the module import graph and asserts

* no import circle between modules,
* no import from a lower stage to a higher one (stage 0 imports nothing of ``solver``
  above it: ``collective`` and ``petscutil`` raise the errors of ``errors``).

Edges not removed yet are listed in ``ALLOWED``; the set only shrinks.
"""
import ast
from functools import lru_cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent / "solver"

# stage of each module: bottom modules by name, the rest by sub-package
BOTTOM = {"solver.errors", "solver.collective", "solver.petscutil", "solver.version",
          "solver.threads"}
PACKAGE_STAGE = {"scene": 1, "model": 2, "partitions": 3, "coupling": 4, "driver": 5, "tools": 6}
TOP = 7                      # solver/__init__, solver/__main__

# (importer, imported) edges that break a rule and have not been removed yet
ALLOWED: set = set()


def module_name(path):
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def all_modules():
    return {module_name(p): p for p in sorted(ROOT.rglob("*.py"))}


def stage(mod):
    if mod in BOTTOM:
        return 0
    parts = mod.split(".")
    if len(parts) == 1 or parts[1] == "__main__":
        return TOP
    return PACKAGE_STAGE[parts[1]]


def resolve(name, modules):
    """The module of ``solver`` that importing ``name`` loads (longest known prefix)."""
    parts = name.split(".")
    while parts:
        cand = ".".join(parts)
        if cand in modules:
            return cand
        parts.pop()
    return None


def imports_of(mod, path, modules):
    """Modules of ``solver`` that ``mod`` imports anywhere in its source."""
    tree = ast.parse(path.read_text(), str(path))
    package = mod if path.name == "__init__.py" else mod.rsplit(".", 1)[0]
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - node.level + 1]
                prefix = ".".join(base + ([node.module] if node.module else []))
            else:
                prefix = node.module or ""
            # `from solver.x import y`: y is a submodule or a name of solver.x
            names = [prefix + "." + a.name if prefix + "." + a.name in modules else prefix
                     for a in node.names]
        else:
            continue
        for n in names:
            target = resolve(n, modules) if n.startswith("solver") else None
            if target and target != mod:
                found.add(target)
    return found


@lru_cache(maxsize=1)
def graph():
    modules = all_modules()
    return {m: imports_of(m, p, modules) for m, p in modules.items()}


def up_stage_edges(g):
    bad = set()
    for a, targets in g.items():
        for b in targets:
            if stage(b) > stage(a):
                bad.add((a, b))
    return bad


def circles(g):
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(g.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(g):
        if v not in index:
            visit(v)
    return out


def test_scan_sees_function_level_imports():
    g = graph()
    # solver/__init__ imports solver.tools.api only inside its functions
    assert "solver.tools.api" in g["solver"]
    assert "solver.errors" in g["solver.scene.schema"]
    assert stage("solver.errors") == 0
    assert stage("solver.model.mesh") == 2
    assert stage("solver.tools.cli") == 6


def test_no_import_circles():
    g = graph()
    pruned = {a: {b for b in t if (a, b) not in ALLOWED} for a, t in g.items()}
    found = circles(pruned)
    assert not found, "import circles:\n" + "\n".join(" <-> ".join(c) for c in found)


def test_no_up_stage_imports():
    bad = up_stage_edges(graph()) - ALLOWED
    assert not bad, "imports that run up the stages:\n" + "\n".join(
        f"{a} (stage {stage(a)}) -> {b} (stage {stage(b)})" for a, b in sorted(bad))


def test_allowed_edges_still_exist():
    """An edge removed from the code leaves ALLOWED too: the set only shrinks."""
    g = graph()
    stale = {(a, b) for a, b in ALLOWED if b not in g.get(a, ())}
    assert not stale, f"remove from ALLOWED: {sorted(stale)}"


@pytest.mark.parametrize("mod", sorted(BOTTOM & set(all_modules())))
def test_bottom_modules_import_only_bottom_modules(mod):
    assert {stage(b) for b in graph()[mod]} <= {0}
