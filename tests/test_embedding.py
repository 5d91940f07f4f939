"""Particles inside coarse cells (Zhang et al. (2009) eq. 3-5): location, weights and the
transfers, to round-off on every cell family."""
import numpy as np
import pytest

from solver.errors import SceneError
from solver.model.elements import FAMILIES
from solver.model.embedding import locate

RNG = np.random.default_rng(7)


def mesh(family):
    """A small distorted mesh of ``family`` cells (points, conn)."""
    if family in ("quad4", "tri3"):
        n = 4
        g = np.stack(np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij"), -1)
        pts = g.reshape(-1, 2).astype(float)
        pts += 0.15 * RNG.uniform(-1, 1, pts.shape) * (np.abs(pts - n / 2) < n / 2)   # inner nodes
        idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
        quads = np.array([[idx[i, j], idx[i + 1, j], idx[i + 1, j + 1], idx[i, j + 1]]
                          for i in range(n) for j in range(n)])
        if family == "quad4":
            return pts, quads
        return pts, np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    n = 3
    g = np.stack(np.meshgrid(*[np.arange(n + 1)] * 3, indexing="ij"), -1)
    pts = g.reshape(-1, 3).astype(float)
    pts += 0.12 * RNG.uniform(-1, 1, pts.shape) * np.all(np.abs(pts - n / 2) < n / 2, axis=1)[:, None]
    idx = np.arange((n + 1) ** 3).reshape(n + 1, n + 1, n + 1)
    hexes = np.array([[idx[i, j, k], idx[i + 1, j, k], idx[i + 1, j + 1, k], idx[i, j + 1, k],
                       idx[i, j, k + 1], idx[i + 1, j, k + 1], idx[i + 1, j + 1, k + 1],
                       idx[i, j + 1, k + 1]] for i in range(n) for j in range(n) for k in range(n)])
    if family == "hex8":
        return pts, hexes
    # Kuhn's six tetrahedra around the main diagonal 0-6: conforming across cubes
    tets = [[0, 1, 2, 6], [0, 2, 3, 6], [0, 3, 7, 6], [0, 7, 4, 6], [0, 4, 5, 6], [0, 5, 1, 6]]
    return pts, np.concatenate([hexes[:, t] for t in tets])


def interior_points(family, X, per_cell=5):
    """Random particles strictly inside every cell, and their true cells."""
    dim = FAMILIES[family].dim
    raw = RNG.uniform(0.05, 0.95, (len(X) * per_cell, dim))
    if family in ("tri3", "tet4"):
        raw = raw / (raw.sum(axis=1, keepdims=True) + RNG.uniform(0.05, 1.0, (len(raw), 1)))
    else:
        raw = 2 * raw - 1
    cells = np.repeat(np.arange(len(X)), per_cell)
    N, _ = FAMILIES[family].shape(raw)
    return np.einsum("pk,pkd->pd", N, X[cells]), cells


@pytest.mark.parametrize("family", ["tri3", "quad4", "tet4", "hex8"])
def test_particles_are_located_and_transfers_conserve(family):
    pts, conn = mesh(family)
    x, true_cell = interior_points(family, pts[conn])
    emb = locate(pts, conn, family, x)
    assert np.array_equal(emb.cell, true_cell)
    assert np.allclose(emb.weights.sum(axis=1), 1.0, rtol=0, atol=1e-13)       # partition of unity
    assert np.allclose(np.einsum("pk,pkd->pd", emb.weights, pts[emb.nodes]), x, atol=1e-12)
    n = len(pts)
    dim = pts.shape[1]
    # forces to nodes (eq. 3): total force and moment kept
    f = RNG.standard_normal((len(x), dim))
    fn = emb.to_nodes(f, n)
    assert np.allclose(fn.sum(axis=0), f.sum(axis=0), atol=1e-12)
    if dim == 3:
        assert np.allclose(np.cross(pts, fn).sum(axis=0), np.cross(x, f).sum(axis=0), atol=1e-11)
    else:
        cross = lambda a, b: a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]               # noqa: E731
        assert np.isclose(cross(pts, fn).sum(), cross(x, f).sum(), atol=1e-11)
    # masses (eq. 5): total mass and momentum of a uniform motion kept
    m = RNG.uniform(0.5, 2.0, len(x))
    mn = emb.to_nodes(m, n)
    assert np.isclose(mn.sum(), m.sum(), rtol=1e-14)
    # velocities back (eq. 4): a rigid-body motion (and any linear field) is exact
    a = RNG.standard_normal(dim)
    W = RNG.standard_normal((dim, dim))
    W = W - W.T                                                                   # rotation rate
    v_nodes = a + pts @ W.T
    assert np.allclose(emb.to_particles(v_nodes), a + x @ W.T, atol=1e-12)
    momentum = (mn[:, None] * np.tile(a, (n, 1))).sum(axis=0)         # nodes at the same velocity
    assert np.allclose(momentum, m.sum() * a, rtol=1e-13)


def test_particle_outside_the_band_is_named():
    pts, conn = mesh("quad4")
    x = np.array([[1.5, 1.5], [9.0, 9.0], [2.5, 0.5]])
    with pytest.raises(SceneError, match=r"transition: particle 1 at \[9.0, 9.0\] lies in no cell"):
        locate(pts, conn, "quad4", x, where="transition")


def test_particle_on_a_shared_face_goes_to_the_lowest_cell():
    pts = np.array([[0, 0], [1, 0], [2, 0], [0, 1], [1, 1], [2, 1]], dtype=float)
    conn = np.array([[1, 2, 5, 4], [0, 1, 4, 3]])              # the edge x = 1 is shared
    emb = locate(pts, conn, "quad4", np.array([[1.0, 0.5]]))
    assert emb.cell.tolist() == [0]
    assert np.allclose(emb.weights[0], [0.5, 0.0, 0.0, 0.5], atol=1e-12)
