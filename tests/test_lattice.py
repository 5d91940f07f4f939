"""Lattice calibration: a uniaxial test recovers E (within 2 %) and nu; masses add up."""
import numpy as np
import pytest

from solver.lattice import bond_triplets, calibrate, square


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
