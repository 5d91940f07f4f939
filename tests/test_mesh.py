"""gmsh meshes: physical groups by name, assembly with block size = dim,
global patch tests, and errors that name the group or the element."""
import dataclasses

import numpy as np
import pytest
from mpi4py import MPI

from solver.partitions.assembly import assemble, group_matrices, nodal
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
