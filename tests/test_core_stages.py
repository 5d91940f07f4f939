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
          "solver.threads", "solver.memory", "solver.laws"}    # laws: the scene's allowed law names come from it
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


# ------------------------------------------------------------------ lazy imports
def lazy_imports_without_reason():
    """Imports inside functions whose line, or the comment line above their run of
    imports, gives no '# lazy:' reason."""
    bad = []
    for mod, path in all_modules().items():
        lines = path.read_text().split("\n")
        tree = ast.parse("\n".join(lines))
        for fn in ast.walk(tree):
            if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            for node in ast.walk(fn):
                if not isinstance(node, (ast.Import, ast.ImportFrom)):
                    continue
                i = node.lineno - 1
                while "# lazy:" not in lines[i] and lines[i - 1].strip().startswith(
                        ("import ", "from ")):
                    i -= 1                              # up the run of imports
                if "# lazy:" not in lines[i] and "# lazy:" not in lines[i - 1]:
                    bad.append(f"{path.relative_to(ROOT.parent)}:{node.lineno}: "
                               f"{lines[node.lineno - 1].strip()}")
    return sorted(set(bad))


def test_every_function_level_import_says_why():
    bad = lazy_imports_without_reason()
    assert not bad, "imports inside functions without a '# lazy:' reason:\n" + "\n".join(bad)


def run_python(code: str, env=None):
    import os
    import subprocess
    import sys
    env = {k: v for k, v in os.environ.items() if k not in THREAD_VARS} | (env or {})
    env["PYTHONPATH"] = str(ROOT.parent)
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=env, cwd=ROOT.parent, timeout=120)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout.split()


THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def test_keys_and_schemes_load_no_heavy_package():
    """`keys`, `schemes` and `--help` start without MPI, PETSc, h5py, scipy, gmsh,
    meshio or matplotlib."""
    loaded = run_python(
        "import contextlib, io, sys\n"
        "from solver.tools import cli\n"
        "for cmd in (['keys'], ['schemes'], ['--help']):\n"
        "    with contextlib.redirect_stdout(io.StringIO()):\n"
        "        cli.main(cmd)\n"
        "print(' '.join(sorted({m.split('.')[0] for m in sys.modules})))")
    heavy = {"mpi4py", "petsc4py", "h5py", "scipy", "gmsh", "meshio", "matplotlib"}
    assert heavy.isdisjoint(loaded), sorted(heavy.intersection(loaded))
    assert "numpy" in loaded and "yaml" in loaded      # the scan sees what it loads


def test_import_solver_sets_no_thread_variables_entry_points_do():
    out = run_python("import os\nimport solver\n"
                     "print([os.environ.get(v) for v in "
                     "('OPENBLAS_NUM_THREADS', 'OMP_NUM_THREADS', 'MKL_NUM_THREADS')])\n"
                     "from solver.tools import cli\nimport contextlib, io\n"
                     "with contextlib.redirect_stdout(io.StringIO()):\n    cli.main(['--help'])\n"
                     "print(os.environ['OPENBLAS_NUM_THREADS'], os.environ['MKL_NUM_THREADS'])")
    assert out == ["[None,", "None,", "None]", "1", "1"]
    # a variable the user set is kept
    out = run_python("import os\nfrom solver.threads import one_blas_thread\none_blas_thread()\n"
                     "print(os.environ['OMP_NUM_THREADS'], os.environ['OPENBLAS_NUM_THREADS'])",
                     env={"OMP_NUM_THREADS": "3"})
    assert out == ["3", "1"]


# ------------------------------------------------------------------ model data
def test_model_data_is_read_once_per_store(monkeypatch):
    """Binding and building a mesh scene with one ModelData read the mesh once;
    without one, each reads it."""
    import os

    from conftest import raw_scene
    from solver.model import arrays, binding, mesh
    from solver.model.data import ModelData
    monkeypatch.chdir(ROOT.parent)
    calls = []
    real = mesh.read
    monkeypatch.setattr(mesh, "read", lambda *a, **k: calls.append(a[0]) or real(*a, **k))
    raw = raw_scene("wave_bar")
    store = ModelData()
    scene = binding.from_dict(raw, store)
    model = arrays.build(scene, None, store)
    assert len(calls) == 1 and len(store) == 1
    assert os.path.basename(calls[0]) == os.path.basename(scene.model.mesh)
    again = arrays.build(binding.from_dict(raw), None)
    assert len(calls) == 3                              # no store: bind and build read
    assert again.n_nodes == model.n_nodes > 0
    assert (again.mass == model.mass).all()


# ------------------------------------------------------------------ the step loop
class FakeScheme:
    def __init__(self, fail_at=None):
        self.times, self.fail_at = [], fail_at

        class Clocks:
            failures = []
        self.clocks = Clocks()

    def step(self, t):
        self.times.append(t)
        if self.fail_at is not None and len(self.times) == self.fail_at:
            raise RuntimeError("diverged")


class FakeStop:
    def __init__(self):
        self.failed, self.polled = None, []

    def fail(self, k, message):
        self.failed = self.failed or (k, message)

    def due(self, k):
        return self.failed is not None

    def poll(self, k):
        self.polled.append(k)
        return (self.failed[0], self.failed[1], False) if self.failed else None


def recorder(log, name, fail_at=None, poll_every=0):
    from solver.driver.observers import Observer

    class Recorder(Observer):
        def start(self, first, last):
            log.append((name, "start", first, last))

        def before_step(self, step):
            log.append((name, "before", step))

        def stepped(self, step):
            log.append((name, "stepped", step))

        def needs_poll(self, step):
            return bool(poll_every) and step % poll_every == 0

        def after_step(self, step, t):
            log.append((name, "after", step, t))
            return f"{name} failed at {step}" if step == fail_at else None

        def finish(self, step, t):
            log.append((name, "finish", step, t))
    return Recorder()


def test_step_loop_calls_observers_in_order():
    from solver.driver.runner import step_loop
    log, stop, scheme = [], FakeStop(), FakeScheme()
    obs = [recorder(log, "a", poll_every=2), recorder(log, "b")]
    failure, done, wall, interrupted = step_loop(scheme, obs, stop, 1, 4, 0.5)
    assert (failure, done, interrupted) == (None, 4, False) and wall >= 0
    assert scheme.times == [0.5, 1.0, 1.5]
    assert stop.polled == [2, 4]                        # a's needs_poll, every 2 steps
    assert log[:2] == [("a", "start", 1, 4), ("b", "start", 1, 4)]
    assert log[2:8] == [("a", "before", 1), ("b", "before", 1), ("a", "stepped", 2),
                        ("b", "stepped", 2), ("a", "after", 2, 1.0), ("b", "after", 2, 1.0)]
    assert log[-2:] == [("a", "finish", 4, 2.0), ("b", "finish", 4, 2.0)]
    assert len(log) == 2 + 3 * 6 + 2


def test_an_observer_failure_ends_the_loop_before_later_observers():
    from solver.driver.runner import step_loop
    log, stop = [], FakeStop()
    obs = [recorder(log, "guard", fail_at=3), recorder(log, "checkpoint")]
    failure, done, _, _ = step_loop(FakeScheme(), obs, stop, 0, 10, 0.25)
    assert (failure, done) == ("guard failed at 3", 3)
    assert ("guard", "after", 3, 0.75) in log and ("checkpoint", "after", 3, 0.75) not in log
    assert ("checkpoint", "after", 2, 0.5) in log
    assert log[-2:] == [("guard", "finish", 3, 0.75), ("checkpoint", "finish", 3, 0.75)]


def test_a_failing_step_stops_at_the_poll():
    from solver.driver.runner import step_loop
    log, stop = [], FakeStop()
    failure, done, _, _ = step_loop(FakeScheme(fail_at=2), [recorder(log, "a")], stop, 0, 10, 1.0)
    assert (failure, done) == ("RuntimeError: diverged", 2)
    assert stop.polled == [2]
    assert ("a", "stepped", 2) not in log and ("a", "after", 2, 2.0) not in log
    assert log[-1] == ("a", "finish", 2, 2.0)


def test_no_module_imports_a_private_name_of_another():
    """``from solver.x import _name`` reaches into another module's privates:
    a name two modules share is public (say so by its name)."""
    found = []
    for mod, path in all_modules().items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("solver"):
                found += [f"{mod}: from {node.module} import {a.name}" for a in node.names
                          if a.name.startswith("_") and not a.name.startswith("__")]
    assert not found, "\n".join(found)


def test_the_loop_calls_only_the_hooks_an_observer_overrides():
    from solver.driver.observers import Observer, hooks

    class Watch(Observer):
        def stepped(self, step):
            return step

    class Other(Observer):
        def after_step(self, step, t):
            return None
    a, b = Watch(), Other()
    assert hooks([a, b], "before_step") == [] and hooks([a, b], "needs_poll") == []
    assert hooks([a, b], "stepped") == [a.stepped] and hooks([a, b], "after_step") == [b.after_step]
