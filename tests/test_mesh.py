"""gmsh meshes: physical groups by name, assembly with block size = dim,
global patch tests, and errors that name the group or the element."""
import dataclasses

import numpy as np
import pytest
from mpi4py import MPI

from solver.model.cell_blocks import group_matrices, nodal
from solver.partitions.assembly import assemble
from solver.model.elements import Elastic
from solver.errors import SceneError
from solver.model.mesh import read
from solver.petscutil import init

AL = {2: Elastic(70e9, 0.33, 2700, "plane_stress", 3.2e-4), 3: Elastic(70e9, 0.33, 2700)}


@pytest.fixture(scope="module", params=["bar2d", "cube3d"])
def mesh(request):
    return read(f"meshes/{request.param}.geo")


def global_system(mesh):
    init([])
    mat = AL[mesh.dim]
    (fam, conn, Ke, me), = group_matrices(mesh, "solid", mat)
    n = len(mesh.points)
    K = assemble(Ke, conn, mesh.dim, n, MPI.COMM_SELF, "test_")
    return K, nodal(me, conn, n), mat


def apply(K, u):
    x = K.createVecRight()
    y = K.createVecLeft()
    x.setArray(u.ravel())
    K.mult(x, y)
    return y.getArray().reshape(u.shape)


def test_structured_bar_has_its_groups():
    m = read("meshes/bar2d.geo")
    assert m.dim == 2 and m.points.shape == (41 * 4, 2)
    assert m.group("solid").cells["quad4"].shape == (120, 4)
    left = m.group("left")
    assert left.dim == 1 and np.allclose(m.points[left.nodes, 0], 0.0) and left.nodes.size == 4


def test_assembled_stiffness(mesh):
    K, mass, mat = global_system(mesh)
    assert K.getBlockSize() == mesh.dim
    P = mesh.points
    scale = K.norm(init().NormType.INFINITY)
    for d in range(mesh.dim):                                   # translations
        u = np.zeros_like(P)
        u[:, d] = 1.0
        assert np.abs(apply(K, u)).max() < 1e-9 * scale
    u = np.zeros_like(P)                                        # a rotation about z
    u[:, 0], u[:, 1] = -P[:, 1], P[:, 0]
    assert np.abs(apply(K, u)).max() < 1e-9 * scale
    volume = mat.measure() * (0.032 * 0.0024 if mesh.dim == 2 else 1.0)
    assert mass.sum() == pytest.approx(mat.rho * volume, rel=1e-12)


def test_uniform_strain_gives_no_interior_force(mesh):
    K, _, _ = global_system(mesh)
    P = mesh.points
    grad = np.random.default_rng(3).standard_normal((mesh.dim, mesh.dim)) * 1e-3
    f = apply(K, P @ grad.T)
    boundary = np.zeros(len(P), bool)
    lo, hi = P.min(axis=0), P.max(axis=0)
    boundary |= np.any(np.isclose(P, lo) | np.isclose(P, hi), axis=1)
    assert np.abs(f[~boundary]).max() < 1e-9 * np.abs(f[boundary]).max()


def test_missing_group_lists_what_the_mesh_has():
    m = read("meshes/bar2d.geo")
    with pytest.raises(SceneError, match=r"model.mesh: mesh has no physical group 'fixed'; "
                                         r"it has: left \(dim 1\), right \(dim 1\), solid \(dim 2\)"):
        m.group("fixed", "model.mesh")


def test_inverted_element_names_its_gmsh_tag():
    m = read("meshes/bar2d.geo")
    solid = m.group("solid")
    conn = solid.cells["quad4"].copy()
    conn[7] = conn[7][::-1]
    bad = dataclasses.replace(m, groups={**m.groups, "solid": dataclasses.replace(
        solid, cells={"quad4": conn})})
    tag = int(solid.cell_tags["quad4"][7])
    with pytest.raises(SceneError, match=rf"group 'solid': gmsh element {tag} \(quad4\) inverted"):
        group_matrices(bad, "solid", AL[2])


def test_unreadable_meshes(tmp_path):
    with pytest.raises(SceneError, match="nope.geo: mesh file not found"):
        read(str(tmp_path / "nope.geo"))
    broken = tmp_path / "broken.geo"
    broken.write_text("Point(1) = {0, 0, 0;\n")
    with pytest.raises(SceneError, match="broken.geo: gmsh could not read it"):
        read(str(broken))


DISC = """// built-in kernel: the circle's centre is a mesh node no cell uses
lc = 0.25;
Point(1) = {0, 0, 0, lc}; Point(2) = {1, 0, 0, lc}; Point(3) = {0, 1, 0, lc};
Point(4) = {-1, 0, 0, lc}; Point(5) = {0, -1, 0, lc};
Circle(1) = {2, 1, 3}; Circle(2) = {3, 1, 4}; Circle(3) = {4, 1, 5}; Circle(4) = {5, 1, 2};
Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};
Physical Surface("solid") = {1}; Physical Curve("rim") = {1, 2, 3, 4};
"""


def test_nodes_no_cell_uses_are_left_out(tmp_path):
    """A circle's centre point is a mesh node outside every cell: the scene binds
    and runs instead of reporting it 'owned by no partition'."""
    from conftest import run_scene
    from solver.model import data as model_data
    from solver.model.binding import from_dict
    (tmp_path / "disc.geo").write_text(DISC)
    raw = {"name": "disc", "time": {"end": 1e-6, "dt": 1e-7},
           "model": {"kind": "continuum", "mesh": str(tmp_path / "disc.geo"), "body": "solid",
                     "material": {"E": 1e9, "nu": 0.3, "rho": 1000.0, "kind": "plane_strain"}},
           "partitions": [{"name": "fem", "method": "fem", "group": "solid",
                           "integrator": "explicit", "ratio": 1}],
           "loads": [{"group": "rim", "kind": "sine", "amplitude": 1e3, "omega": 1e5}],
           "probes": [{"name": "c", "at": [0.0, 0.0]}]}
    scene = from_dict(raw)
    mesh = model_data.read(scene.model)
    used = np.unique(np.concatenate([c.ravel() for c in mesh.group("solid").cells.values()]))
    assert used.size == len(mesh.points) - 1               # the centre point
    assert sorted(scene.partitions[0].nodes) == used.tolist()
    assert scene.probes[0].node in used                    # snapped to a body node
    result = run_scene(raw, tmp_path)
    assert result.attrs["status"] == "completed"
    assert result.attrs["n_system_steps"] == 10
