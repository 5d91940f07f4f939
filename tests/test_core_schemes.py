"""One declared class per coupling scheme (solver/coupling/scheme.py), one
registry (solver/scene/registry.py): every scheme declares its facts, the
scene's allowed values, ``python -m solver schemes`` and docs/scene.md come
from the registry, a scheme registered from outside is accepted and asked for
its rules, the guard and the launch ask the class, and the coupling, driver and
tools read no other module's private attributes."""
import ast
import copy
import typing

import pytest

from conftest import ROOT, raw_scene, run_cli
from solver.errors import LaunchError, SceneError

BUILT_IN = ("overlap", "staggered", "gc", "conserving", "transition")


def parsed(raw):
    from solver.scene import Scene
    from solver.scene.schema import parse
    return parse(Scene, copy.deepcopy(raw))


def network(scheme="overlap", integrators=("explicit", "verlet"), methods=("fem", "dem"),
            ratios=(1, 1)):
    return {"name": "n", "time": {"end": 1.0, "dt": 0.01},
            "model": {"kind": "network", "masses": [1.0, 1.0],
                      "springs": [["ground", 0, 1.0], [0, 1, 1.0]]},
            "partitions": [{"name": f"p{k}", "method": m, "nodes": [k], "integrator": i,
                            "ratio": r}
                           for k, (m, i, r) in enumerate(zip(methods, integrators, ratios))],
            "coupling": {"scheme": scheme}}


@pytest.fixture
def toy():
    """A scheme defined outside the solver: registered while the test runs."""
    from solver.coupling.scheme import Scheme
    from solver.scene import registry
    from solver.scene.schema import fail

    class Toy(Scheme):
        name = "toy"
        summary = "a toy for the registry test"
        about = "a scheme that refuses every scene"
        supports = "nothing"
        limit = "none"
        uses_external = False
        max_ranks = 3

        @classmethod
        def validate(cls, scene):
            fail("coupling.scheme", f"toy: refused by its own rule ({len(scene.partitions)} "
                 "partitions)")
    try:
        yield Toy
    finally:
        registry.unregister("toy")
    assert "toy" not in registry.names()


def test_every_registered_scheme_declares_every_fact():
    from solver.coupling.scheme import FACTS, Scheme
    from solver.scene import registry
    declared = registry.declared()
    assert tuple(declared) == BUILT_IN
    assert [cls.__name__ for cls in declared.values()] == [
        "ConcurrentOverlap", "Staggered", "GravouilCombescure", "Conserving", "TransitionZone"]
    for name, cls in declared.items():
        assert issubclass(cls, Scheme) and cls.name == name
        for fact in ("summary", "about", "supports", "limit"):
            text = getattr(cls, fact)
            assert isinstance(text, str) and len(text) > 20 and "{" not in text, (name, fact)
        assert isinstance(cls.uses_external, bool)
        assert cls.max_ranks is None or (isinstance(cls.max_ranks, int) and cls.max_ranks >= 1)
        assert set(FACTS) <= set(dir(cls))
    assert {n for n, c in declared.items() if c.uses_external} == {"overlap", "staggered",
                                                                    "transition"}
    assert {n: c.max_ranks for n, c in declared.items()} == {
        "overlap": None, "staggered": None, "gc": None, "conserving": None, "transition": None}


def test_a_scheme_missing_a_fact_is_refused_when_defined():
    from solver.coupling.scheme import Scheme
    from solver.scene import registry
    with pytest.raises(TypeError, match="'half' does not declare about, supports, limit"):
        class Half(Scheme):                              # noqa: F841
            name = "half"
            summary = "declares too little"
            uses_external = False
            max_ranks = None
    assert "half" not in registry.names()


def test_the_tables_of_schemes_py_are_views_of_the_registry():
    from solver.coupling import schemes
    from solver.scene import registry
    declared = registry.declared()
    assert schemes.ABOUT == {n: c.about for n, c in declared.items()}
    assert schemes.SUPPORT == {n: c.supports for n, c in declared.items()}
    assert schemes.LIMIT == {n: c.limit for n, c in declared.items()}
    assert schemes.MAX_RANKS == {}
    assert all(schemes.scheme_class(n) is c for n, c in declared.items())


def test_the_scene_key_allows_exactly_the_registry_names():
    from solver.scene import Coupling, registry
    from solver.scene.schema import describe
    assert registry.names() == BUILT_IN
    row = next(r for r in describe(Coupling) if r[0] == "scheme")
    assert row[1] == " | ".join(BUILT_IN) and row[2] == "'overlap'"
    assert row[3] == "; ".join(f"{n}: {c.summary}" for n, c in registry.declared().items())
    assert typing.get_type_hints(Coupling)["scheme"] is str
    for name in BUILT_IN:                        # every name passes the key (its rules may not)
        try:
            parsed(network(name))
        except SceneError as e:
            assert "is not one of" not in str(e), (name, e)
    with pytest.raises(SceneError, match=r"^coupling.scheme: 'lagrange' is not one of overlap, "
                                         r"staggered, gc, conserving, transition$"):
        parsed(network("lagrange"))
    with pytest.raises(SceneError, match=r"^coupling.scheme: 3 is not one of overlap, "):
        parsed(network(3))
    assert parsed(network("overlap")).scheme is registry.lookup("overlap")


def test_importing_the_scene_imports_no_coupling_module():
    import subprocess
    import sys
    code = ("import sys, solver.scene; "
            "print(sorted(m for m in sys.modules if m.startswith('solver.coupling')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                         env={"PYTHONPATH": str(ROOT), "PATH": ""}, check=True).stdout
    assert out.strip() == "[]"


def test_a_registered_toy_scheme_is_listed_accepted_and_asked_for_its_rules(toy, capsys):
    from solver.scene import Coupling, registry
    from solver.scene.schema import describe
    from solver.tools.cli import print_schemes, schemes_markdown
    assert registry.names() == BUILT_IN + ("toy",) and registry.lookup("toy") is toy
    with pytest.raises(SceneError, match=r"^coupling.scheme: toy: refused by its own rule "
                                         r"\(2 partitions\)$"):
        parsed(network("toy"))
    row = next(r for r in describe(Coupling) if r[0] == "scheme")
    assert row[1].endswith("| transition | toy") and row[3].endswith("; toy: a toy for the "
                                                                      "registry test")
    print_schemes()
    out = capsys.readouterr().out
    assert ("  toy: a scheme that refuses every scene.\n    supports: nothing.\n"
            "    stability: none.\n") in out
    assert schemes_markdown().splitlines()[-1] == ("| `toy` | a scheme that refuses every scene "
                                                    "| nothing | none |")
    with pytest.raises(LaunchError, match="^coupling.scheme toy runs on 1 to 3 ranks, not 4$"):
        toy.check_launch(None, 4)
    toy.check_launch(None, 3)
    with pytest.raises(TypeError, match="'toy' is already registered"):
        from solver.coupling.scheme import Scheme

        class Again(Scheme):                              # noqa: F841
            name, summary, about, supports, limit = "toy", "s", "a", "s", "l"
            uses_external, max_ranks = False, None


def test_schemes_lists_every_registered_scheme_with_its_texts():
    from solver.scene import registry
    proc = run_cli(["schemes"])
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout
    at = [out.index(f"\n  {name}: ") for name in registry.names()]
    assert at == sorted(at)                                    # in registry order
    for name, cls in registry.declared().items():
        assert (f"  {name}: {cls.about}.\n    supports: {cls.supports}.\n    stability: "
                f"{cls.limit}.\n") in out


def test_docs_scheme_table_is_generated_from_the_registry():
    from solver.scene import registry
    from solver.tools.cli import keys_markdown, schemes_markdown
    text = (ROOT / "docs" / "scene.md").read_text()
    table = schemes_markdown()
    assert table in text and keys_markdown() in text
    rows = table.splitlines()[2:]
    assert [r.split(" | ")[0] for r in rows] == [f"| `{n}`" for n in registry.names()]
    assert "| `coupling.scheme` | overlap \\| staggered \\| gc \\| conserving \\| transition |" \
        in keys_markdown()


def test_the_launch_asks_the_scheme():
    from solver.coupling.conserving import Conserving
    from solver.coupling.gc import GravouilCombescure
    from solver.coupling.system_step import ConcurrentOverlap
    gc = parsed(network("gc", ("explicit", "implicit"), ("fem", "fem"), (1, 2)))
    for size in (1, 2, 64):                      # any number of ranks
        GravouilCombescure.check_launch(gc, size)
    raw = network("conserving", ("explicit", "implicit"), ("fem", "fem"), (1, 2))
    raw["partitions"][0]["beta"] = 0.0
    Conserving.check_launch(parsed(raw), 4)           # any N, each side on several ranks
    raw["partitions"][1]["ranks"] = 2
    Conserving.check_launch(parsed(raw), 3)
    ConcurrentOverlap.check_launch(parsed(network()), 64)


@pytest.mark.parametrize("motion, cap", [("predictor", 1.15), ("linear", 1.15),
                                         ("velocity", 0.65), ("hold", 0.2)])
def test_the_guard_asks_the_scheme_for_its_step_limit(motion, cap):
    from solver.partitions import stability
    raw = raw_scene("wave_bar_transition")
    raw["coupling"]["band_motion"] = motion
    raw.pop("damping")                                   # the integrator's own limit: 2
    scene = parsed(raw)
    fem = next(p for p in scene.partitions if p.method == "fem")
    dem = next(p for p in scene.partitions if p.method == "dem")
    rule = scene.scheme
    assert rule.name == "transition"
    assert rule.step_limit(scene, fem, 2.0) == (cap, f"; the transition scheme keeps "
                                                     f"omega_max * fdt < {cap:.3g}")
    assert rule.step_limit(scene, dem, 2.0) == (2.0, "")
    assert stability.coupled_fe(scene, fem) and not stability.coupled_fe(scene, dem)
    fdt = fem.ratio * scene.time.dt
    fr = stability.Frequency(1.01 * cap / fdt, "exact")       # just beyond the cap
    crit, problem = stability.verdict(scene, fem, fr)
    assert crit == pytest.approx(fdt / 1.01, rel=1e-12)
    assert problem.endswith(f"exact; the transition scheme keeps omega_max * fdt < {cap:.3g}); "
                            "reduce time.dt or the ratio"), problem
    assert stability.verdict(scene, fem, stability.Frequency(0.99 * cap / fdt, "exact"))[1] is None
    other = parsed(dict(network(), coupling={"scheme": "overlap"}))
    assert other.scheme.step_limit(other, other.partitions[0], 2.0) == (2.0, "")
    assert other.scheme.built_problems(other, {}) == []
    assert other.scheme.refusal_context(other, {"p0": (None, 1.0)}) is None


def test_the_transition_scheme_names_the_damping_it_needs():
    from solver.partitions import stability
    raw = raw_scene("wave_bar_transition")
    raw["damping"] = {"beta": 1e-9}
    scene = parsed(raw)
    assert scene.system_ratio > 1
    dem = next(p for p in scene.partitions if p.method == "dem")
    fr = stability.Frequency(4e6, "exact")
    need = 2 * stability.TRANSITION_XI / 4e6                   # 5e-9 s
    problem, = scene.scheme.built_problems(scene, {dem.name: (fr, 0.5e-6)})
    assert problem.startswith(f"damping.beta: 1e-09 s: the transition scheme sub-cycles (FE step "
                              f"{scene.system_ratio} x the DE step) and needs damping.beta >= "
                              f"{need:.3g} s"), problem
    raw["damping"] = {"beta": 1e-8}
    scene = parsed(raw)
    assert scene.scheme.built_problems(scene, {dem.name: (fr, 0.5e-6)}) == []
    assert scene.scheme.dropped == "the transition scheme runs without the damping it needs"


# --- no branch on a scheme's name, no private attributes across modules -------

SCHEME_MODULES = {"solver/coupling/scheme.py", "solver/coupling/system_step.py",
                  "solver/coupling/gc.py", "solver/coupling/conserving.py",
                  "solver/coupling/transition_zone.py", "solver/coupling/schemes.py"}


def _strings(node):
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return {node.value}
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        return set().union(*(_strings(e) for e in node.elts)) if node.elts else set()
    return set()


def test_no_module_outside_the_scheme_classes_tests_a_scheme_name():
    """``x == "gc"``, ``x in ("staggered", "conserving")``, ``x != "transition"``..."""
    found = []
    for path in sorted((ROOT / "solver").rglob("*.py")):
        rel = path.relative_to(ROOT).as_posix()
        if rel in SCHEME_MODULES:
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Compare):
                names = set().union(*(_strings(x) for x in [node.left, *node.comparators]))
                if names & set(BUILT_IN):
                    found.append(f"{rel}:{node.lineno}: {ast.unparse(node)}")
    assert not found, "\n".join(found)


# No module of coupling/, driver/ or tools/ reads a `_` attribute of another object:
# tests/test_core_partition.py scans every module outside partitions/ for that.
