"""The 2D beam bond between rotating particles (solver/partitions/beam_bond.py;
issue 25): rigid motions exert nothing, forces and torques are the energy's
gradients and balance, small motions give the Timoshenko beam element, and a
cantilever of bonded particles follows beam theory and the elastica."""
from __future__ import annotations

import numpy as np
import pytest

from solver.partitions.beam_bond import BeamBonds


def cluster(seed=3, n=7):
    """A random cluster: n particles, every pair closer than 1.6 bonded."""
    rng = np.random.default_rng(seed)
    X = rng.uniform(0.0, 2.0, (n, 2))
    i, j = np.triu_indices(n, 1)
    near = np.linalg.norm(X[j] - X[i], axis=1) < 1.6
    i, j = i[near], j[near]
    bonds = BeamBonds(i, j, X[j] - X[i], rng.uniform(1.0, 3.0, i.size),
                      rng.uniform(0.1, 0.3, i.size), rng.uniform(0.0, 0.5, i.size))
    return X, bonds, rng


@pytest.mark.parametrize("angle", [0.3, 2.5, 7.0, -4.0])
def test_a_rigid_motion_exerts_nothing(angle):
    """Any translation and rotation of a bonded cluster, the particles turning
    with it (beyond pi and several turns too): no force, torque or energy."""
    X, bonds, rng = cluster()
    R = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    u = (X - X.mean(axis=0)) @ R.T + X.mean(axis=0) + rng.normal(size=2) - X
    theta = np.full(len(X), angle)
    f, t = bonds.forces(u, theta)
    assert np.abs(f).max() < 1e-12 and np.abs(t).max() < 1e-12
    assert bonds.energy(u, theta) < 1e-24


def test_forces_and_torques_are_the_energy_gradients_and_balance():
    """At a random large deformation: f = -dE/dx and torque = -dE/dtheta (central
    differences, 1e-7), the forces sum to zero and the torques with the
    forces' moments too (angular momentum is kept); a bond's resultants
    (N, V, M_i, M_j) are the loads it puts on its ends."""
    X, bonds, rng = cluster()
    u = rng.normal(0.0, 0.15, X.shape)
    theta = rng.normal(0.0, 0.4, len(X))
    f, t = bonds.forces(u, theta)
    h = 1e-6
    for p in range(len(X)):
        for c in range(2):
            du = np.zeros_like(u)
            du[p, c] = h
            grad = (bonds.energy(u + du, theta) - bonds.energy(u - du, theta)) / (2 * h)
            assert abs(f[p, c] + grad) < 1e-7 * max(1.0, abs(grad)), (p, c)
        dt = np.zeros_like(theta)
        dt[p] = h
        grad = (bonds.energy(u, theta + dt) - bonds.energy(u, theta - dt)) / (2 * h)
        assert abs(t[p] + grad) < 1e-7 * max(1.0, abs(grad)), p
    x = X + u
    # a lone bond's resultants are its forces: -N along e1 and V along e2 on j,
    # the torques -M_i and -M_j
    a, b = bonds.i[0], bonds.j[0]
    alone = BeamBonds([a], [b], bonds.rest[:1], bonds.k_n[0], 1.0, 0.3)
    fa, ta = alone.forces(u, theta)
    N, V, M_i, M_j = (r[0] for r in alone.resultants(u, theta))
    e1 = (x[b] - x[a]) / np.linalg.norm(x[b] - x[a])
    assert abs(np.dot(fa[b], e1) + N) < 1e-12 * max(1.0, abs(N))
    assert abs(np.dot(fa[b], [-e1[1], e1[0]]) - V) < 1e-12 * max(1.0, abs(V))
    assert abs(ta[a] + M_i) < 1e-12 and abs(ta[b] + M_j) < 1e-12
    assert np.abs(f.sum(axis=0)).max() < 1e-12
    assert abs(t.sum() + np.sum(x[:, 0] * f[:, 1] - x[:, 1] * f[:, 0])) < 1e-12


def jacobian(bonds, m, u=None, theta=None, h=1e-7):
    """d(-f, -torque)/d(u, theta) [3m, 3m] by central differences, DOFs per
    particle (u_x, u_y, theta)."""
    u = np.zeros((m, 2)) if u is None else u
    theta = np.zeros(m) if theta is None else theta
    K = np.zeros((3 * m, 3 * m))

    def load(u, theta):
        f, t = bonds.forces(u, theta, m)
        return -np.column_stack([f, t]).ravel()
    for p in range(m):
        for c in range(3):
            du, dt = np.zeros_like(u), np.zeros_like(theta)
            if c < 2:
                du[p, c] = h
            else:
                dt[p] = h
            K[:, 3 * p + c] = (load(u + du, theta + dt) - load(u - du, theta - dt)) / (2 * h)
    return K


@pytest.mark.parametrize("alpha", [0.0, 0.7, 2.0])
def test_small_motions_give_the_timoshenko_beam_element(alpha):
    """At rest the bond's stiffness is the Timoshenko beam element's
    (axial EA/L, bending EI/(L^3 (1 + Phi)) [12, 6L, (4 + Phi) L^2,
    (2 - Phi) L^2]) turned to the bond's direction, to 1e-6."""
    L, EA, EI, Phi = 1.3, 5.0, 0.4, 0.3
    e = np.array([np.cos(alpha), np.sin(alpha)])
    bonds = BeamBonds([0], [1], [L * e], EA / L, EI / L, Phi)
    K = jacobian(bonds, 2)
    c = EI / (L ** 3 * (1 + Phi))
    local = np.zeros((6, 6))
    local[np.ix_([0, 3], [0, 3])] = EA / L * np.array([[1, -1], [-1, 1]])
    local[np.ix_([1, 2, 4, 5], [1, 2, 4, 5])] = c * np.array([
        [12, 6 * L, -12, 6 * L],
        [6 * L, (4 + Phi) * L ** 2, -6 * L, (2 - Phi) * L ** 2],
        [-12, -6 * L, 12, -6 * L],
        [6 * L, (2 - Phi) * L ** 2, -6 * L, (4 + Phi) * L ** 2]])
    T = np.eye(6)
    for at in (0, 3):
        T[at:at + 2, at:at + 2] = [[e[0], -e[1]], [e[1], e[0]]]
    assert np.abs(K - T @ local @ T.T).max() < 1e-6 * np.abs(local).max()


def cantilever(n, P, EI=1.0, EA=1e4, Phi=0.0, length=1.0, loads=8):
    """A chain of n bonds along x, particle 0 clamped (u = theta = 0), a load P
    down on the tip, solved by Newton's method in ``loads`` increments:
    the tip's (downward deflection, shortening) / length."""
    a = length / n
    m = n + 1
    bonds = BeamBonds(np.arange(n), np.arange(1, n + 1), np.tile([a, 0.0], (n, 1)), EA / a,
                      EI / a, Phi)
    free = np.arange(3, 3 * m)
    q = np.zeros(3 * m)
    for step in range(1, loads + 1):
        f_ext = np.zeros(3 * m)
        f_ext[3 * n + 1] = -P * step / loads
        for _ in range(30):
            u, theta = q.reshape(m, 3)[:, :2], q.reshape(m, 3)[:, 2]
            f, t = bonds.forces(u, theta, m)
            r = f_ext + np.column_stack([f, t]).ravel()
            if np.abs(r[free]).max() < 1e-9 * P:
                break
            K = jacobian(bonds, m, u.copy(), theta.copy())
            step = np.linalg.solve(K[np.ix_(free, free)], r[free])
            q[free] += step
            if np.abs(step).max() < 1e-14 * length:
                break
        else:
            raise AssertionError("Newton did not converge")
    return -q[3 * n + 1] / length, -q[3 * n] / length


def test_a_cantilever_of_bonded_particles_follows_timoshenko_beam_theory():
    """Small load: the tip deflection of 10 bonds is P L^3 / (3 EI) +
    P L / (kappa G A) (exact for beam elements under an end load), to 1e-6."""
    EI, Phi, L, P, n = 2.0, 0.2, 1.0, 1e-3, 10
    a = L / n
    kGA = 12 * EI / (Phi * a ** 2)
    tip, _ = cantilever(n, P, EI=EI, Phi=Phi, loads=1)
    assert abs(tip / (P * L ** 3 / (3 * EI) + P * L / kGA) - 1) < 1e-6


def test_a_packed_cantilever_bends_as_the_continuum_within_2_percent():
    """A random packing 20 spacings deep and 160 long (seed 2, 2061 particles),
    beam bonds calibrated to E and nu 0.25 (benchmarks/bench_cantilever.py):
    clamped over the first spacing, loaded over the last, its tip deflection is
    the same strip's of plane-stress quadrilaterals (Richardson from h = 1/2 and
    1/4 spacing) within 2 % (measured 1.004; seeds 1-4: 0.985-1.004)."""
    import sys

    from conftest import ROOT
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from bench_cantilever import reference, tip_deflection
    ref, change = reference(0.25, 20.0)
    assert change < 1e-3
    assert abs(tip_deflection(0.25, 20.0, 2)[2] / ref - 1) < 0.02


def elastica(load):
    """Tip (deflection, shortening) / L of the inextensible cantilever under a
    tip load with P L^2 / EI = ``load``: theta'' = -load cos(theta), theta(0)
    = 0, theta'(1) = 0, by shooting (scipy)."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import brentq

    def shoot(k0):
        s = solve_ivp(lambda s, y: [y[1], -load * np.cos(y[0]), np.cos(y[0]), np.sin(y[0])],
                      (0, 1), [0.0, k0, 0.0, 0.0], rtol=1e-12, atol=1e-12)
        return s.y[:, -1]
    k0 = brentq(lambda k: shoot(k)[1], 0.0, load)
    end = shoot(k0)
    return end[3], 1.0 - end[2]


def test_a_large_deflection_cantilever_follows_the_elastica():
    """P L^2 / EI = 2 (the tip turns by about 40 degrees): 40 bonds give the
    elastica's tip deflection (0.4935 L) and shortening (0.1606 L) within
    1e-3 (measured 2e-4 and 4e-4), which a small-strain bond (deflection
    P L^3 / 3 EI = 0.67 L) misses by 35 %."""
    tip, short = cantilever(40, 2.0)
    want_tip, want_short = elastica(2.0)
    assert abs(tip / want_tip - 1) < 1e-3 and abs(short / want_short - 1) < 1e-3
    assert want_tip < 0.75 * 2.0 / 3


@pytest.mark.parametrize("size", [0.3, 1e-4])
def test_the_compiled_loop_is_the_numpy_law(size):
    """solver/partitions/beam_bond_kernel.py at a large random deformation
    (rotations beyond pi: atan2) and a small one (chords turned by less than
    0.01 rad: atan's series): the numpy law's forces and torques to 1e-12;
    rows beyond ``rows`` (another piece's particles) are left alone."""
    from solver.partitions.beam_bond_kernel import beam_forces
    X, bonds, rng = cluster(seed=5, n=40)
    u = rng.normal(0.0, size, X.shape)
    theta = rng.normal(0.0, 8 * size, len(X))
    f, t = bonds.forces(u, theta)
    out = np.zeros((len(X), 3))
    assert beam_forces(bonds, np.column_stack([u, theta]), out) == 0
    scale = max(np.abs(f).max(), np.abs(t).max())
    assert np.abs(out[:, :2] - f).max() < 1e-12 * scale
    assert np.abs(out[:, 2] - t).max() < 1e-12 * scale
    part = np.full((len(X), 3), 7.0)
    beam_forces(bonds, np.column_stack([u, theta]), part, rows=30, accumulate=True)
    assert np.array_equal(part[30:], np.full((10, 3), 7.0))
    assert np.abs(part[:30] - 7.0 - out[:30]).max() < 1e-12 * scale


def one_bond(tension, shear, friction=0.0):
    """A bond of length 1 along x (k_n 100, k_b 1) with strengths."""
    bonds = BeamBonds([0], [1], [[1.0, 0.0]], 100.0, 1.0)
    bonds.breakable(tension, shear, friction)
    return bonds


def breaks(bonds, u, theta):
    """(how many broke, their mode, the forces) of one evaluation of the loop."""
    from solver.partitions.beam_bond_kernel import beam_forces
    snapped, mode = np.zeros(1, np.int64), np.zeros(1, np.int64)
    out = np.zeros((2, 3))
    n = beam_forces(bonds, np.column_stack([u, theta]), out, snapped=snapped, mode=mode)
    return n, int(mode[0]) if n else 0, out


def test_a_beam_breaks_in_tension_at_its_outer_fibre_and_in_shear_by_mohr_coulomb():
    """Strengths of a beam (Potyondy & Cundall's parallel bond): stretched to
    its tensile strain it breaks in tension (mode 1) and then pulls nothing;
    bent with its chord fixed (both ends turned by phi, end moments 6 k_b phi)
    it breaks in tension once the outer fibre's strain 6 phi sqrt(3 k_b / k_n)
    / L0 reaches the limit, with no stretch at all; sheared (an end moved
    across, shear |V| / (k_n L0) = 12 k_b beta / (k_n L0)) with a high
    tensile strength it breaks in shear (mode 2), and compression across it
    raises that strength by friction x its compressive strain."""
    eps = 1e-2
    for s, broke in ((0.999, 0), (1.001, 1)):
        n, mode, out = breaks(one_bond(eps, 1.0), np.array([[0, 0], [s * eps, 0]]), np.zeros(2))
        assert (n, mode) == (broke, broke)
        assert (np.abs(out).max() == 0.0) == bool(broke)
    phi = eps / (6.0 * np.sqrt(0.03))                 # outer fibre at the limit
    for s, broke in ((0.999, 0), (1.001, 1)):
        assert breaks(one_bond(eps, 1.0), np.zeros((2, 2)), np.full(2, s * phi))[:2] == \
            (broke, broke)
    beta = 5e-3 / 0.12                                # |V| / (k_n L0) = 0.12 beta at the limit
    for s, broke in ((0.999, 0), (1.001, 2)):
        u = np.array([[0.0, 0.0], [0.0, np.tan(s * beta)]])
        n, mode, _ = breaks(one_bond(1.0, 5e-3), u, np.zeros(2))
        assert (n, mode) == (int(broke > 0), broke)
    u = np.array([[0.0, 0.0], [-0.02, np.tan(1.2 * beta) * 0.98]])   # 2 % shorter, sheared
    assert breaks(one_bond(1.0, 5e-3), u, np.zeros(2))[0] == 1
    assert breaks(one_bond(1.0, 5e-3, friction=0.5), u, np.zeros(2))[0] == 0
    fibre, slip, t_lim, s_lim = one_bond(1.0, 5e-3, 0.5).failure(u, np.zeros(2))
    assert slip[0] > 5e-3 and s_lim[0] == pytest.approx(5e-3 + 0.5 * (1 - np.hypot(0.98, u[1, 1])),
                                                        rel=1e-9)
