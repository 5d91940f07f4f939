"""The 3D beam bond between rotating particles (solver/partitions/beam_bond3d.py;
issue 25): rigid motions of any size exert nothing, forces and torques are the
energy's gradients and keep momentum and angular momentum, small motions give
the space-frame beam element, a chain of bonds bends as the elastica in any
plane and twists as a shaft, the compiled loop is the numpy law, and bonds
break at their outer fibre, in shear and in torsion."""
from __future__ import annotations

import numpy as np
import pytest

from solver.model.calibration import beam_blocks3d
from solver.partitions.beam_bond3d import BeamBonds3D, rotations
from solver.partitions.beam_bond3d_kernel import beam_forces3d
from test_beam_bond import elastica


def cluster(seed=3, n=7, reach=1.8):
    """A random cluster: n particles in a box of side 2 (3 for n > 10), pairs closer
    than ``reach`` bonded (sorted by their first particle)."""
    rng = np.random.default_rng(seed)
    X = rng.uniform(0.0, 2.0 if n <= 10 else 3.0, (n, 3))
    i, j = np.triu_indices(n, 1)
    near = np.linalg.norm(X[j] - X[i], axis=1) < reach
    i, j = i[near], j[near]
    bonds = BeamBonds3D(i, j, X[j] - X[i], rng.uniform(1.0, 3.0, i.size),
                        rng.uniform(0.1, 0.3, i.size), rng.uniform(0.1, 0.3, i.size),
                        rng.uniform(0.0, 0.5, i.size))
    return X, bonds, rng


@pytest.mark.parametrize("angle", [0.3, 2.5, 7.0])
def test_a_rigid_motion_exerts_nothing(angle):
    """Any translation and any rotation (about a random axis, beyond pi and a
    whole turn too) of a bonded cluster, its particles turning with it: no
    force, torque or energy (1e-12)."""
    X, bonds, rng = cluster()
    axis = rng.normal(size=3)
    theta = angle * axis / np.linalg.norm(axis)
    R = rotations(theta[None])[0]
    u = (X - X.mean(axis=0)) @ R.T + X.mean(axis=0) + rng.normal(size=3) - X
    f, t = bonds.forces(u, np.tile(theta, (len(X), 1)))
    assert np.abs(f).max() < 1e-12 and np.abs(t).max() < 1e-12
    assert bonds.energy(u, np.tile(theta, (len(X), 1))) < 1e-24


def test_forces_and_moments_are_the_energy_gradients_and_balance():
    """At a random large deformation (rotations of 0.4 rad): f = -dE/du and
    the moments m = -dE/dw for a spin dw of a particle, R -> exp([dw]x) R
    (central differences, 1e-7), the forces sum to zero and the moments
    with the forces' moments too."""
    X, bonds, rng = cluster()
    u = rng.normal(0.0, 0.15, X.shape)
    R = rotations(rng.normal(0.0, 0.4, X.shape))
    f, t = bonds.forces(u, R)
    h = 1e-6
    for p in range(len(X)):
        for c in range(3):
            d = np.zeros_like(u)
            d[p, c] = h
            grad = (bonds.energy(u + d, R) - bonds.energy(u - d, R)) / (2 * h)
            assert abs(f[p, c] + grad) < 1e-7 * max(1.0, abs(grad)), (p, c)
            spun = [R.copy(), R.copy()]
            for sign, S in zip((1, -1), spun):
                S[p] = rotations(sign * d[p][None])[0] @ R[p]
            grad = (bonds.energy(u, spun[0]) - bonds.energy(u, spun[1])) / (2 * h)
            assert abs(t[p, c] + grad) < 1e-7 * max(1.0, abs(grad)), (p, c)
    assert np.abs(f.sum(axis=0)).max() < 1e-12
    x = X + u
    assert np.abs(t.sum(0) + np.cross(x, f).sum(0)).max() < 1e-12


def frame_element(L, EA, EI, GJ):
    """The space-frame (Euler-Bernoulli) element along x, DOFs (u, theta) of
    each end."""
    K = np.zeros((12, 12))
    K[np.ix_([0, 6], [0, 6])] = EA / L * np.array([[1, -1], [-1, 1]])
    K[np.ix_([3, 9], [3, 9])] = GJ / L * np.array([[1, -1], [-1, 1]])
    a, b, c, d = 12 * EI / L ** 3, 6 * EI / L ** 2, 4 * EI / L, 2 * EI / L
    for w, r, s in ((1, 5, 1.0), (2, 4, -1.0)):       # (v, theta_z), (w, -theta_y)
        idx = [w, r, w + 6, r + 6]
        K[np.ix_(idx, idx)] = np.array([[a, s * b, -a, s * b], [s * b, c, -s * b, d],
                                        [-a, -s * b, a, -s * b], [s * b, d, -s * b, c]])
    return K


@pytest.mark.parametrize("seed", [0, 1])
def test_small_motions_give_the_space_frame_element(seed):
    """At rest the bond's stiffness (the law differentiated numerically) and
    calibration.beam_blocks3d are both the space-frame element (axial EA/L,
    torsion GJ/L, bending EI/L^3 [12, 6L, 4L^2, 2L^2] in both planes) turned
    to the bond's direction, to 1e-6."""
    rng = np.random.default_rng(seed)
    L, EA, EI, GJ = 1.3, 5.0, 0.4, 0.3
    e = rng.normal(size=3)
    e /= np.linalg.norm(e)
    bonds = BeamBonds3D([0], [1], [L * e], EA / L, EI / L, GJ / L)
    K = np.zeros((12, 12))
    for k in range(12):
        dq = np.zeros((2, 6))
        dq.ravel()[k] = 1e-7
        plus, minus = (np.hstack(bonds.forces(q[:, :3], q[:, 3:])).ravel() for q in (dq, -dq))
        K[:, k] = -(plus - minus) / 2e-7
    t = np.cross(e, [1.0, 0.0, 0.0] if abs(e[0]) < 0.9 else [0.0, 1.0, 0.0])
    t /= np.linalg.norm(t)
    Rl = np.column_stack([e, t, np.cross(e, t)])           # local x, y, z in global axes
    T = np.kron(np.eye(4), Rl)
    want = T @ frame_element(L, EA, EI, GJ) @ T.T
    assert np.abs(K - want).max() < 1e-6 * np.abs(want).max()
    blocks = beam_blocks3d(np.array([L * e]), np.array([EA / L]), np.array([EI / L]),
                           np.array([GJ / L]))[0]
    assert np.abs(blocks - want).max() < 1e-12 * np.abs(want).max()


def chain(n, load, length=1.0, EI=1.0, EA=1e4, GJ=0.8, steps=8, axis=(1.0, 0.0, 0.0)):
    """A chain of n bonds along ``axis``, particle 0 clamped, the tip loaded by
    ``load`` (force, moment) [6] in ``steps`` increments, solved by Newton's
    method (Jacobian: the compiled loop differentiated): the tip's q [6]."""
    axis = np.asarray(axis) / np.linalg.norm(axis)
    a, m = length / n, n + 1
    bonds = BeamBonds3D(np.arange(n), np.arange(1, m), np.tile(a * axis, (n, 1)), EA / a,
                        EI / a, GJ / a)
    free = np.arange(6, 6 * m)
    q = np.zeros((m, 6))

    def residual(q, f_ext):
        out = np.zeros((m, 6))
        beam_forces3d(bonds, q, out)
        return (f_ext + out).ravel()[free]
    for step in range(1, steps + 1):
        f_ext = np.zeros((m, 6))
        f_ext[n] = np.asarray(load) * step / steps
        for _ in range(30):
            r = residual(q, f_ext)
            if np.abs(r).max() < 1e-10 * np.abs(load).max():
                break
            K = np.zeros((free.size, free.size))
            for k, dof in enumerate(free):
                dq = np.zeros(6 * m)
                dq[dof] = 1e-7
                K[:, k] = -(residual(q + dq.reshape(m, 6), f_ext) -
                            residual(q - dq.reshape(m, 6), f_ext)) / 2e-7
            q.ravel()[free] += np.linalg.solve(K, r)
        else:
            raise AssertionError("Newton did not converge")
    return q[n]


def test_a_chain_bends_as_the_elastica_in_any_plane_and_twists_as_a_shaft():
    """A cantilever of 20 bonds with P L^2 / EI = 2 at the tip (its end turns
    by 40 degrees): the elastica's tip deflection 0.4935 L within 1e-2
    (the bond measures the tilt by its sine; measured 7.5e-4), the same along
    y and along z, and along a chain laid on a skew axis; a tip torque T
    turns the tip by T L / GJ (1e-6)."""
    want, _ = elastica(2.0)
    tip_y = chain(20, [0, -2.0, 0, 0, 0, 0])
    tip_z = chain(20, [0, 0, -2.0, 0, 0, 0])
    assert abs(-tip_y[1] / want - 1) < 1e-2, tip_y[1]
    assert tip_z[2] == pytest.approx(tip_y[1], rel=1e-9)
    assert tip_y[5] == pytest.approx(-tip_z[4], rel=1e-9)     # about z, about -y
    axis = np.array([1.0, 2.0, -0.5]) / np.linalg.norm([1.0, 2.0, -0.5])
    across = np.cross(axis, [0.0, 0.0, 1.0])
    across /= np.linalg.norm(across)
    skew = chain(20, np.concatenate([-2.0 * across, np.zeros(3)]), axis=axis)
    assert np.dot(skew[:3], across) == pytest.approx(tip_y[1], rel=1e-7)
    twist = chain(20, [0, 0, 0, 1e-3, 0, 0], steps=1)
    assert twist[3] == pytest.approx(1e-3 * 1.0 / 0.8, rel=1e-6)      # (measured 2.6e-9)


@pytest.mark.parametrize("size", [0.3, 1e-5])
def test_the_compiled_loop_is_the_numpy_law(size):
    """solver/partitions/beam_bond3d_kernel.py at a large random deformation
    (rotations of 2.4 rad) and a small one (rotations below 1e-3: the
    coefficients' series): the numpy law's forces and torques to 1e-12;
    rows beyond ``rows`` (another piece's particles) are left alone."""
    X, bonds, rng = cluster(seed=5, n=40, reach=1.2)
    q = np.hstack([rng.normal(0.0, size, X.shape), rng.normal(0.0, 8 * size, X.shape)])
    f, t = bonds.forces(q[:, :3], q[:, 3:])
    out = np.zeros((len(X), 6))
    assert beam_forces3d(bonds, q, out) == 0
    scale = max(np.abs(f).max(), np.abs(t).max())
    assert np.abs(out - np.hstack([f, t])).max() < 1e-12 * scale
    part = np.full((len(X), 6), 7.0)
    beam_forces3d(bonds, q, part, rows=30, accumulate=True)
    assert np.array_equal(part[30:], np.full((10, 6), 7.0))
    assert np.abs(part[:30] - (7.0 + out[:30])).max() < 1e-12 * (7.0 + scale)


def breaks(bonds, q):
    """(how many broke, their mode, the loads) of one evaluation of the loop."""
    snapped, mode = np.zeros(1, np.int64), np.zeros(1, np.int64)
    out = np.zeros((2, 6))
    n = beam_forces3d(bonds, q, out, snapped=snapped, mode=mode)
    return n, int(mode[0]) if n else 0, out


def one_bond(tension, shear, friction=0.0):
    """A bond of length 1 along x (k_n 100, k_b 1, k_t 1) with strengths."""
    bonds = BeamBonds3D([0], [1], [[1.0, 0.0, 0.0]], 100.0, 1.0, 1.0)
    bonds.breakable(tension, shear, friction)
    return bonds


def test_a_bond_breaks_at_its_outer_fibre_in_shear_and_in_torsion():
    """The parallel bond's strengths on a circular section (c / (E_b I) =
    2 sqrt(k_b / k_n) / (k_b L0) = 0.2): stretched to its tensile strain it
    breaks in tension (mode 1) and then pulls nothing; bent with its chord
    fixed (both ends turned by phi about z, end moments 6 k_b phi) it breaks in
    tension once the outer fibre's strain 1.2 phi reaches the limit; twisted
    by tau it breaks in shear (mode 2) once k_t tau c / (E_b J) = 0.1 tau
    reaches the shear limit, and the same bond bent about y breaks the same
    as about z."""
    eps = 1e-2
    rest = np.zeros((2, 6))
    for s, broke in ((0.999, 0), (1.001, 1)):
        q = rest.copy()
        q[1, 0] = s * eps
        n, mode, out = breaks(one_bond(eps, 1.0), q)
        assert (n, mode) == (broke, broke)
        assert (np.abs(out).max() == 0.0) == bool(broke)
    phi = eps / 1.2
    for axis in (5, 4):
        for s, broke in ((0.999, 0), (1.001, 1)):
            q = rest.copy()
            q[:, axis] = s * phi
            assert breaks(one_bond(eps, 1.0), q)[:2] == (broke, broke)
    tau = 5e-3 / 0.1
    for s, broke in ((0.999, 0), (1.001, 2)):
        q = rest.copy()
        q[1, 3] = np.arcsin(s * tau)                  # the measure: sin of the twist
        assert breaks(one_bond(1.0, 5e-3), q)[:2] == (int(broke > 0), broke)


def test_broken_bond_records_name_their_columns():
    """/broken_bonds' columns attribute names every column: central bonds 6 +
    dim, beams 8 + dim with mode and energy (3D beams: 11)."""
    from solver.driver.output import broken_columns
    assert broken_columns(9).split(", ")[1:4] == ["x", "y", "z"]
    names = broken_columns(11).split(", ")
    assert len(names) == 11 and names[7:9] == ["mode", "energy"]
    assert len(broken_columns(8).split(", ")) == 8 and len(broken_columns(10).split(", ")) == 10
