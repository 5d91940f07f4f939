"""meshes/u_tube_graded.geo (docs/shells.md, "The graded mesh"): Ma et al.'s
(2018) U-tube meshed finer at the impact and at the bend, coarser elsewhere,
around the tube and along it.  Coarse parameters (h_min 0.05 m, h_max 0.4 m:
976 nodes) keep it fast; the bounds are the measured values with a margin."""
import numpy as np
import pytest

from conftest import raw_scene, run_cli

COARSE = {"h_min": 0.05, "h_max": 0.4}
IMPACT = np.array([3.0, 0.0, 1.0])          # top of the apex cross-section (Rb, 0, r)
BINS = [1, 2, 4, 8, np.inf]                 # the time-step levels dt_min x 1, 2, 4, 8


@pytest.fixture(scope="module")
def built():
    """(scene, model, per-triangle estimated steps L/c, triangle centres) of the
    coarse graded U-tube, as set-up measures them (element_steps)."""
    from solver import scene as scene_mod
    from solver.model import arrays, binding, element_steps
    raw = raw_scene("u_tube_graded")
    raw["model"]["mesh_parameters"] = dict(COARSE)
    raw["output"] = {"file": "unused.h5"}
    scene = binding.bind(scene_mod.from_dict(raw))
    mdl = arrays.build(scene)
    (conn, Ke), = mdl.stiffness_blocks(np.arange(mdl.n_nodes))     # the shell triangles
    steps, _ = element_steps.element_steps(scene, mdl, [(conn, Ke)])
    return scene, mdl, steps, mdl.points[np.asarray(conn)].mean(axis=1)


def test_the_groups_of_the_uniform_mesh_are_there():
    """tube = explicit + implicit (the 30-degree sector of the bend around the
    impact and the rest), symmetry on the plane y = 0, clamped at the leg's end
    x = -6 m: configs/u_tube.yaml's partitions and conditions apply as they are."""
    from solver.model.mesh import read
    mesh = read("meshes/u_tube_graded.geo", parameters=COARSE, gdim=3)
    assert set(mesh.groups) == {"tube", "explicit", "implicit", "symmetry", "clamped"}
    tri = {g: mesh.group(g).cells["tri3"] for g in ("tube", "explicit", "implicit")}
    assert len(tri["tube"]) == len(tri["explicit"]) + len(tri["implicit"])
    assert 1800 < len(tri["tube"]) < 2000                   # 1896 with gmsh 4.15.2
    P = mesh.points
    sym, clamped = P[mesh.group("symmetry").nodes], P[mesh.group("clamped").nodes]
    assert mesh.group("symmetry").dim == mesh.group("clamped").dim == 1
    assert np.abs(sym[:, 1]).max() < 1e-12 and np.allclose(np.hypot(sym[:, 0] - 3, sym[:, 2]), 1)
    assert np.abs(clamped[:, 0] + 6).max() < 1e-12
    # the explicit sector: the impact node, and angles about z of 0..30 degrees
    c = P[tri["explicit"]].mean(axis=1)
    angle = np.degrees(np.arctan2(c[:, 1], c[:, 0]))
    assert angle.min() > 0 and angle.max() < 30
    assert np.linalg.norm(P[np.unique(tri["explicit"])] - IMPACT, axis=1).min() < 1e-12


def test_sizes_grow_from_the_impact_in_both_directions(built):
    """The largest estimated step is 14.3 x the smallest (the uniform mesh's: 1.7 x).
    The 10 smallest triangles lie within 0.11 m of the impact, and every triangle
    farther than 1 m from it has 1.81 x the smallest step or more (the bend-leg
    circle's, at h_bend = 2 h_min).  The median size grows from the impact's
    (triangles within 0.15 m) around the tube (to the bottom of the same
    cross-section: 6.8 x) and along it (to the middle of the leg's top: 7.7 x)."""
    _, _, steps, centre = built
    assert steps.max() / steps.min() > 12
    distance = np.linalg.norm(centre - IMPACT, axis=1)
    assert distance[np.argsort(steps)[:10]].max() < 0.12
    assert steps[distance > 1.0].min() > 1.6 * steps.min()

    def median_near(point, radius):
        return np.median(steps[np.linalg.norm(centre - point, axis=1) < radius])
    at_impact = median_near(IMPACT, 0.15)
    assert median_near(np.array([3.0, 0.0, -1.0]), 0.4) > 5 * at_impact      # around
    assert median_near(np.array([-3.0, 3.0, 1.0]), 0.4) > 5 * at_impact      # along


def test_most_triangles_are_in_the_coarse_step_levels(built):
    """Shares of triangles over dt_min x [1,2), [2,4), [4,8), [8,inf) (measured:
    1.0, 30.3, 17.8, 50.8 %): the impact's level is small, half are 8 x coarser."""
    _, _, steps, _ = built
    share = np.histogram(steps / steps.min(), bins=BINS)[0] / len(steps)
    assert share[0] < 0.03 and share[3] > 0.45 and share[2] + share[3] > 0.6, share


def test_the_graded_scene_runs_and_keeps_its_energy(tmp_path):
    """configs/u_tube_graded.yaml on the coarse mesh, 40 system steps (0.48 ms):
    it completes, the impact node moves down, kinetic + strain = the load's work
    to 1e-5 of it while the load rises (measured: 1.0e-6)."""
    import h5py
    out = tmp_path / "g.h5"
    sets = [f"model.mesh_parameters.{k}={v}" for k, v in COARSE.items()] + [
        "time.end=0.00048", "output.energy_every=4", f"output.file={out}"]
    proc = run_cli(["configs/u_tube_graded.yaml", *[a for s in sets for a in ("--set", s)]])
    assert proc.returncode == 0, proc.stderr
    with h5py.File(out) as f:
        u = f["probes/impact/displacement"][()]
        e = {k: f[f"energy/{k}"][()] for k in ("kinetic", "strain", "external_work")}
    assert u[-1] < -1e-5
    balance = e["kinetic"] + e["strain"] - e["external_work"]
    assert np.abs(balance).max() < 1e-5 * e["external_work"].max()
