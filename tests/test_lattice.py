"""Lattice calibration: a uniaxial test recovers E (within 2 %) and nu; masses add up."""
import numpy as np
import pytest

from solver.model.lattice import bond_triplets, calibrate, square


@pytest.mark.parametrize("kind,nu", [("plane_stress", 0.33), ("plane_strain", 0.25)])
def test_uniaxial_lattice_recovers_E_and_nu(kind, nu):
    E, rho, t, a = 70e9, 2700.0, 3.2e-4, 1e-4
    lat = square((0, 0), (41, 21), a, E, nu, rho, t, kind)
    n = len(lat.points)
    r, c, v = bond_triplets(lat.points, lat.bond_i, lat.bond_j, lat.stiffness)
    K = np.zeros((2 * n, 2 * n))
    np.add.at(K, (r, c), v)
    # prescribe u_x = eps x on the left and right columns, free elsewhere (incl. u_y)
    eps = 1e-4
    x, y = lat.points.T
    L, H = x.max(), y.max()
    fixed = np.zeros(2 * n, bool)
    ends = np.isclose(x, 0) | np.isclose(x, L)
    fixed[2 * np.flatnonzero(ends)] = True
    fixed[2 * np.argmin(x + y) + 1] = True                      # no rigid vertical motion
    u = np.zeros(2 * n)
    u[2 * np.flatnonzero(ends)] = eps * x[ends]
    free = ~fixed
    u[free] = np.linalg.solve(K[np.ix_(free, free)], -K[np.ix_(free, fixed)] @ u[fixed])
    f = K @ u
    force = f[2 * np.flatnonzero(np.isclose(x, L))].sum()
    thick = t if kind == "plane_stress" else 1.0
    E_plane = force / (H * thick) / eps
    E_expected = E if kind == "plane_stress" else E / (1 - nu ** 2)
    assert abs(E_plane / E_expected - 1) < 0.02, (E_plane, E_expected)
    mid = np.isclose(x, L / 2)
    lateral = -(u[2 * np.flatnonzero(mid & np.isclose(y, H)) + 1] -
                u[2 * np.flatnonzero(mid & np.isclose(y, 0)) + 1])[0] / H / eps
    assert abs(lateral - 1 / 3) < 0.01                           # lattice Poisson ratio
    assert lat.mass.sum() == pytest.approx(rho * thick * L * H, rel=1e-12)


def test_poisson_ratio_outside_the_lattice_range_is_refused():
    with pytest.raises(ValueError, match="represents nu = 0.333 in plane_stress; the material has nu = 0.2"):
        calibrate(70e9, 0.2, 1e-3, "plane_stress")


def test_uniaxial_cubic_lattice_recovers_E_and_nu():
    from solver.model.lattice import cubic
    E, rho, a = 70e9, 2700.0, 1e-4
    lat = cubic((0, 0, 0), (13, 7, 7), a, E, 0.25, rho)
    n = len(lat.points)
    r, c, v = bond_triplets(lat.points, lat.bond_i, lat.bond_j, lat.stiffness, dim=3)
    K = np.zeros((3 * n, 3 * n))
    np.add.at(K, (r, c), v)
    eps = 1e-4
    x, y, z = lat.points.T
    L, H, W = x.max(), y.max(), z.max()
    ends = np.isclose(x, 0) | np.isclose(x, L)
    fixed = np.zeros(3 * n, bool)
    fixed[3 * np.flatnonzero(ends)] = True
    corner = np.argmin(x + y + z)
    fixed[3 * corner + 1] = fixed[3 * corner + 2] = True          # no rigid lateral motion
    fixed[3 * np.argmin(x + y - z) + 1] = True                      # no rotation about x
    u = np.zeros(3 * n)
    u[3 * np.flatnonzero(ends)] = eps * x[ends]
    free = ~fixed
    u[free] = np.linalg.solve(K[np.ix_(free, free)], -K[np.ix_(free, fixed)] @ u[fixed])
    force = (K @ u)[3 * np.flatnonzero(np.isclose(x, L))].sum()
    assert abs(force / (H * W) / eps / E - 1) < 0.02
    mid = np.isclose(x, L / 2)
    top, bottom = mid & np.isclose(y, H) & np.isclose(z, 0), mid & np.isclose(y, 0) & np.isclose(z, 0)
    lateral = -(u[3 * np.flatnonzero(top) + 1] - u[3 * np.flatnonzero(bottom) + 1])[0] / H / eps
    assert abs(lateral - 0.25) < 0.01
    assert lat.mass.sum() == pytest.approx(rho * L * H * W, rel=1e-12)
    with pytest.raises(ValueError, match="simple cubic lattice with face-diagonal bonds represents nu = 0.25"):
        cubic((0, 0, 0), (3, 3, 3), a, E, 0.33, rho)


def test_overlap_cells_are_found_by_their_corners_in_any_order():
    """continuum.same_corners against a set of sorted corner tuples (what
    attach_lattice used before): random cells, wanted rows given reversed,
    absent rows, repeated rows, and cells of another width (never a match)."""
    from solver.model.continuum import same_corners
    rng = np.random.default_rng(3)
    hits = 0
    for _ in range(20):
        conn = rng.integers(0, 30, (200, 4))
        wanted = np.sort(np.concatenate([conn[rng.choice(200, 20, replace=False)][:, ::-1],
                                         rng.integers(0, 30, (10, 4))]), axis=1)
        sets = {tuple(sorted(c)) for c in wanted.tolist()}
        ref = np.array([tuple(sorted(c)) in sets for c in conn.tolist()])
        assert np.array_equal(same_corners(conn, wanted), ref)
        hits += int(ref.sum())
    assert hits >= 20 * 20                       # every trial matched its 20 picked cells
    assert not same_corners(conn[:, :3], wanted).any()
    assert not same_corners(conn, wanted[:0]).any()


def _bonds_by_sorting(lat, keep):
    """The reference: every kept cell's contributions listed, then summed per
    bond by np.unique and bincount (what the lattice did before)."""
    shape = lat.shape
    idx = np.arange(int(np.prod(shape))).reshape(shape)
    cells = tuple(n - 1 for n in shape)
    at = {}
    for a, b, _ in lat.contributions:
        for o in (a, b):
            at[o] = idx[tuple(slice(x, x + n) for x, n in zip(o, cells))].ravel()
    keep = np.asarray(keep).ravel()
    i = np.concatenate([at[a][keep] for a, _, _ in lat.contributions])
    j = np.concatenate([at[b][keep] for _, b, _ in lat.contributions])
    k = np.concatenate([np.full(keep.sum(), w) for _, _, w in lat.contributions])
    n = len(lat.points)
    key = np.minimum(i, j) * n + np.maximum(i, j)
    uniq, inv = np.unique(key, return_inverse=True)
    return uniq // n, uniq % n, np.bincount(inv, weights=k)


@pytest.mark.parametrize("dim", [2, 3])
def test_bonds_summed_over_the_grid_equal_the_sorted_list_of_cell_contributions(dim):
    """Lattice.bonds sums each direction's contributions on the site grid; the
    same bonds, in the same order, with the same stiffness to the last bit as
    listing every kept cell's contributions and summing them per bond, for
    all cells, random cells and no cells."""
    from solver.model.lattice import cubic
    rng = np.random.default_rng(3)
    lat = (square((0, 0), (9, 7), 1e-3, 70e9, 0.33, 2700.0, 1e-3) if dim == 2 else
           cubic((0, 0, 0), (6, 5, 4), 1e-3, 70e9, 0.25, 2700.0))
    n_cells = len(lat.corners)
    for keep in (np.ones(n_cells, bool), rng.random(n_cells) < 0.6, np.zeros(n_cells, bool)):
        got = lat.bonds(keep)
        ref = _bonds_by_sorting(lat, keep)
        assert len(got[0]) == len(ref[0]) and (len(got[0]) > 0) == keep.any()
        for g, r in zip(got, ref):
            assert np.array_equal(g, r) and (g.dtype == r.dtype or not len(g))
    assert len(lat.bond_i) == (9 * 6 + 8 * 7 + 2 * 8 * 6 if dim == 2 else
                               5 * 5 * 4 + 6 * 4 * 4 + 6 * 5 * 3 + 2 * (5 * 4 * 4 + 5 * 5 * 3 + 6 * 4 * 3))
