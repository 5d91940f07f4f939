"""The shell triangle's three membranes (solver/model/shell_membrane.py) on
the quick part of the shell obstacle course (benchmarks/shell_course.py; the
whole course: benchmarks/bench_shells.py, docs/benchmarks/bench_shells.md),
ANDES's exact in-plane bending, and model.material.membrane from a scene to
the static solve."""
import sys

import numpy as np
import pytest

from conftest import ROOT, raw_scene, run_scene
from solver.model import shell

sys.path.insert(0, str(ROOT / "benchmarks"))
from shell_course import course, grid, solve  # noqa: E402


@pytest.mark.parametrize("cells", [6, 30])
def test_andes_bends_in_plane_exactly(cells):
    """A clamped strip 6 x 0.2 (nu = 0), one element deep, aspect 5 and 1,
    under a tip couple: ANDES gives M L^2 / (2 E I) to 0.02 % and 0.5 %;
    Allman's membrane a fraction of it (0.15 and 0.61), the constant-strain
    one less."""
    E, t, L, w = 1e7, 0.1, 6.0, 0.2
    pts, tri, idx = grid(cells, 1, lambda s, r: np.stack([s * L, (r - 0.5) * w, 0 * s], 1))
    forces = np.zeros(6 * len(pts))
    forces[6 * idx[-1, 0]], forces[6 * idx[-1, 1]] = 1 / w, -1 / w       # M = 1
    exact = L ** 2 / (2 * E * t * w ** 3 / 12)
    from shell_course import Case
    case = Case("couple", pts, tri, E, 0.0, t, [(idx[0, :], range(6))], forces, idx[-1, :], 1,
                exact, f"{cells}x1")
    assert solve(case, "andes") == pytest.approx(1.0, abs=3e-4 if cells == 6 else 6e-3)
    allman = solve(case, "allman")
    assert allman < (0.2 if cells == 6 else 0.65)
    assert solve(case, "cst") < allman


@pytest.mark.parametrize("name, n, membrane, low, high", [
    ("hemisphere", 8, "cst", 0.98, 1.0),           # drilling decoupled: no locking
    ("hemisphere", 8, "andes", 0.45, 0.55),        # its drilling rotations lock here
    ("twist_thin_z", 2, "cst", 0.96, 1.0),         # 12 x 2, t = 0.0032
    ("twist_thick_y", 2, "andes", 0.99, 1.01),
    ("roof", 16, "andes", 0.99, 1.01),
    ("cylinder", 16, "cst", 0.98, 1.02),
    ("straight_regular_inplane", 0, "andes", 1.0, 1.06),
    ("straight_regular_inplane", 0, "allman", 0.15, 0.25),
])
def test_obstacle_course_quick(name, n, membrane, low, high):
    """Displacement / the literature's reference on the course's meshes, each
    bound around the figure docs/benchmarks/bench_shells.md reports."""
    assert low <= solve(course(name, n), membrane) <= high


@pytest.mark.parametrize("membrane", ["cst", "andes"])
def test_the_scene_key_reaches_the_static_solve(tmp_path, membrane):
    """configs/plate_shell.yaml solved statically under an in-plane point load
    at the centre with model.material.membrane: the centre's in-plane
    displacement is the one K of shell.stiffness(kind=membrane), assembled
    here on the same mesh, gives (1e-9)."""
    from solver.model import binding, shell_model
    from solver.model.data import ModelData
    raw = raw_scene("plate_shell")
    raw["model"]["material"]["membrane"] = membrane
    raw.update(analysis="static", time={"end": 1.0},
               loads=[{"at": [0.5, 0.5, 0.0], "component": 0, "kind": "rectangular",
                       "amplitude": 1000.0, "duration": 2.0}],
               probes=[{"name": "centre", "at": [0.5, 0.5, 0.0], "component": 0}])
    got = run_scene(raw, tmp_path).probes["centre"]["displacement"][0]

    scene = binding.from_dict(raw)
    mesh = ModelData().read(scene.model)
    model = shell_model.build(scene, mesh)
    (_, conn, _), = model["cells"]
    pts, m = model["points"], scene.model.material
    K = shell.stiffness(pts[conn], m.E, m.nu, m.thickness, kind=membrane)
    n = 6 * len(pts)
    Kg = np.zeros((n, n))
    dofs = (6 * conn[:, :, None] + np.arange(6)).reshape(len(conn), 18)
    for e in range(len(conn)):
        Kg[np.ix_(dofs[e], dofs[e])] += K[e]
    centre = int(np.argmin(np.linalg.norm(pts - [0.5, 0.5, 0.0], axis=1)))
    f = np.zeros(n)
    f[6 * centre] = 1000.0
    free = ~model["fixed"]
    u = np.zeros(n)
    u[free] = np.linalg.solve(Kg[np.ix_(free, free)], f[free])
    assert got == pytest.approx(u[6 * centre], rel=1e-9)


def test_the_stable_step_follows_the_membrane(tmp_path):
    """configs/plate_shell.yaml (16 x 16 x 2, 10 mm, physical rotary inertia):
    the guard's critical step is 1.71 us with Allman's membrane, 1.17 us with
    ANDES (its drilling rotations are stiffer) and 6.89 us with the constant-
    strain membrane (soft drilling: the membrane and bending then set it), as
    ARPACK finds on the same operator (benchmarks/bench_shells.py); ANDES is
    refused at 1.01 x its step and runs at 0.99 x."""
    from conftest import run_cli, write_scene

    def dynamic(membrane, dt):
        raw = raw_scene("plate_shell")
        raw["model"]["material"]["membrane"] = membrane
        raw["time"] = {"end": 10 * dt, "dt": dt}
        raw["output"] = {"file": str(tmp_path / f"{membrane}{dt}.h5")}
        return raw
    crit = {m: run_scene(dynamic(m, 1e-7), tmp_path).partitions["plate"]["critical_step"]
            for m in ("allman", "andes", "cst")}
    assert crit["allman"] == pytest.approx(1.71e-6, rel=0.01), crit
    assert crit["andes"] == pytest.approx(1.17e-6, rel=0.01), crit
    assert crit["cst"] == pytest.approx(6.89e-6, rel=0.01), crit
    for factor, code in ((1.01, 2), (0.99, 0)):
        path = write_scene(tmp_path / f"a{factor}.yaml", dynamic("andes", factor * crit["andes"]))
        proc = run_cli([path])
        assert proc.returncode == code, (factor, proc.stderr)
        if code:
            assert "critical step" in proc.stderr, proc.stderr


def test_a_checkpoint_knows_its_membrane():
    """The restart fingerprint leaves the key out while allman (checkpoints
    written before the key existed still restart) and tells the others apart."""
    from solver.driver.state import fingerprint
    from solver.model import binding
    prints = {}
    for m in (None, "allman", "andes", "cst"):
        raw = raw_scene("plate_shell")
        if m:
            raw["model"]["material"]["membrane"] = m
        prints[m] = fingerprint(binding.from_dict(raw))
    assert prints[None] == prints["allman"]
    assert len({prints["allman"], prints["andes"], prints["cst"]}) == 3
