"""Contact of rotating particles (model.lattice.bond: beam with
model.lattice.contact; 2D, and 3D with rotation vectors): the shear spring's
contact point, half way between the centres, rolls with the particles'
rotations, and the tangential force's
moment turns both particles (solver/partitions/contact.py).  The compiled
loops against the numpy path, angular momentum kept to round-off, the energy
audit of a sticking and sliding cluster, and a rigidly turning pair that
strains no spring."""
from __future__ import annotations

import numpy as np
import pytest

from test_contact_history import jittered

R = 0.5


def contact(kn, mass, zeta=0.0, mu=0.3, zeta_t=0.0, history=True, compiled=True, h=1e-3,
            rotary=True, rolling=0.0, radii=None):
    from solver.laws import CONTACT_LAWS, ContactSettings
    from solver.partitions.contact import Contact
    settings = ContactSettings(CONTACT_LAWS["linear"](kn), R if radii is None else radii.max(),
                               0.1, zeta, mu, zeta_t, history=history, rolling_friction=rolling)
    none = np.zeros(0, np.int64)
    return Contact(np.arange(len(mass)), settings, none, none, mass, dt=h, compiled=compiled,
                   rotary=rotary, radii=radii)


def cluster(n=10, seed=3):
    """A jittered n x n packing with random velocities and spins: positions
    and velocities with the rotation last, masses, rotary inertias."""
    X, v = jittered(n, 2, seed)
    rng = np.random.default_rng(seed)
    mass = rng.uniform(0.5, 2.0, len(X))
    inertia = 0.5 * mass * R ** 2
    q = np.column_stack([X, np.zeros(len(X))])
    w = np.column_stack([v, rng.normal(0.0, 8.0, len(X))])
    return q, w, np.column_stack([mass, mass, inertia])


def verlet(contacts, q, w, m, h, steps, viscous=True):
    """Velocity Verlet of the particles under ``contacts`` (the first one's
    forces drive them; every one is evaluated and their results returned per
    step); yields (q, w, [(force, viscous force, power, energy, slipped,
    touching) per contact])."""
    N = len(q)
    a = np.zeros_like(q)
    for _ in range(steps):
        q += h * w + 0.5 * h * h * a
        w += 0.5 * h * a
        got = []
        for c in contacts:
            f, g = np.zeros_like(q), np.zeros_like(q)
            c.forces(q, np.zeros(0, bool), f, N)
            power = c.viscous(w, g, N) if viscous else 0.0
            got.append((f, g, power, c.energy, c._slipped, c.touching()))
        a = (got[0][0] + got[0][1]) / m
        w += 0.5 * h * a
        yield q, w, got


@pytest.mark.parametrize("history, rolling", [(True, 0.0), (False, 0.0), (True, 0.1)])
def test_the_compiled_loops_turn_the_particles_as_the_numpy_path(history, rolling):
    """A jittered packing of rotating particles stepped with velocity Verlet:
    at every step the compiled loops' forces and torques, dashpot and
    friction forces and torques (and rolling springs'), energy, work of
    sliding and rolling and touching pairs equal the numpy path's (to 1e-12
    of the largest), through search rebuilds; the torques are not small
    (the spins matter)."""
    q, w, m = cluster()
    kn, h = 2e5, 0.02 / np.sqrt(2e5)
    args = dict(zeta=0.3, mu=0.2, zeta_t=0.3, history=history, h=h, rolling=rolling)
    compiled_equals_numpy(q, w, m, kn, 150, 2, **args)


def compiled_equals_numpy(q, w, m, kn, steps, dim, **args):
    """Step the particles by the compiled contact loops while the numpy path
    evaluates the same states: forces and torques, dashpot and friction,
    power, energy, slid work and touching pairs equal at every step (1e-12
    of the largest force), both rebuild alike (more than once), and the
    torques are not small (at least 0.05 R x the largest force)."""
    fast, ref = contact(kn, m[:, 0], **args), contact(kn, m[:, 0], compiled=False, **args)
    assert fast.compiled and not ref.compiled
    biggest = 0.0
    for _, _, got in verlet([fast, ref], q, w, m, args["h"], steps):
        (f, g, p, e, s, t), (f0, g0, p0, e0, s0, t0) = got
        scale = np.abs(f0[:, :dim]).max()
        assert np.abs(f - f0).max() <= 1e-12 * scale and np.abs(g - g0).max() <= 1e-12 * scale
        assert abs(p - p0) <= 1e-12 * abs(p0) and abs(e - e0) <= 1e-12 * e0
        assert abs(s - s0) <= 1e-12 * max(s0, 1e-300)
        assert np.array_equal(t[0], t0[0]) and np.array_equal(t[1], t0[1])
        biggest = max(biggest, np.abs((f0 + g0)[:, dim:]).max() / (R * scale))
    assert fast.builds == ref.builds > 1
    assert biggest > 0.05, biggest


def audit(rotary, fraction=1.0, rolling=0.0):
    """A free cluster of spinning particles (or particles that do not turn)
    stepped by ``fraction`` x 0.05 / sqrt(k) to the same time: the largest
    change of the angular momentum (over its scale sum m |x| |v|) and of the
    energy (over its start), and the work of sliding (over the energy)."""
    q, w, m = cluster(seed=5)
    if not rotary:
        q, w, m = q[:, :2].copy(), w[:, :2].copy(), m[:, :2]
    kn = 2e5
    h = fraction * 0.05 / np.sqrt(kn)
    c = contact(kn, m[:, 0], mu=0.3, h=h, rotary=rotary, rolling=rolling)

    def angular(q, w):
        return float(np.sum(m[:, 0] * (q[:, 0] * w[:, 1] - q[:, 1] * w[:, 0]))
                     + (np.sum(m[:, 2] * w[:, 2]) if rotary else 0.0))

    def kinetic(w):
        return 0.5 * float(np.sum(m * w * w))

    start = contact(kn, m[:, 0], rotary=rotary)               # the packing starts pressed
    start.forces(q, np.zeros(0, bool), np.zeros_like(q), len(q))
    L0, E0 = angular(q, w), kinetic(w) + start.energy
    scale = float(np.sum(m[:, 0] * np.linalg.norm(q[:, :2], axis=1) *
                         np.linalg.norm(w[:, :2], axis=1)))
    slid = drift = change = 0.0
    for q, w, got in verlet([c], q, w, m, h, round(1500 / fraction), viscous=False):
        _, _, _, e, s, _ = got[0]
        slid += s
        drift = max(drift, abs(kinetic(w) + e + slid - E0) / E0)
        change = max(change, abs(angular(q, w) - L0) / scale)
    return change, drift, slid / E0


def test_angular_momentum_is_kept_and_the_energy_audit_closes():
    """A free cluster of spinning particles, shear springs sticking and
    sliding (10 % of the energy slides away), no dashpots: velocity Verlet
    keeps the angular momentum sum m x cross v + I omega to round-off (1e-12
    of its scale; measured 5e-14: the moment of the tangential forces about
    the contact point half way balances the pair's forces' moment exactly);
    kinetic (translation and rotation) + spring energy + the work of
    sliding stays within 1e-2 of the start (measured 5.5e-3), first order in
    the step as without rotation (the work of sliding is counted per step:
    halving the step halves the error; measured 1.98).  Particles that do
    not turn (tangential forces without their moments) change it by more
    than 1 %."""
    change, drift, slid = audit(True)
    assert slid > 0.05, slid
    assert change < 1e-12, change
    assert drift < 1e-2, drift
    _, finer, _ = audit(True, 0.5)
    assert 1.7 < drift / finer < 2.3, drift / finer
    change, _, _ = audit(False)
    assert change > 1e-2, change


def test_rolling_resistance_keeps_angular_momentum_and_the_audit():
    """The cluster above with rolling resistance mu_r 0.1: the rolling
    springs' moments are equal and opposite, so the angular momentum is kept
    to 1e-12 (measured 3e-14); the audit (their energy held and what their
    cap takes) closes as without them (measured 5.8e-3 against 5.5e-3), and
    more of the energy goes (rolling dissipates too: 11.7 % against
    10.2 %)."""
    change, drift, slid = audit(True, rolling=0.1)
    assert change < 1e-12, change
    assert drift < 1e-2, drift
    assert slid > 1.1 * audit(True)[2], slid


def test_a_rolling_spring_holds_then_rolls_then_unloads_elastically():
    """Two pressed particles turned in opposite senses (theta_0 = a,
    theta_1 = -a: the one rolls on the other, no slip at the contact point):
    the shear spring stays unloaded, the rolling spring turns particle 0 by
    -k_r phi and particle 1 by k_r phi (phi = 2a, k_r = k_t R*^2, R* = r/2)
    while below mu_r R* f_n, then at that cap (rolling: the energy the cap
    takes, mu_r R* f_n x the further rolling, is dissipated); turned back,
    it unloads along k_r.  When the pair opens, the spring's last energy is
    dissipated too."""
    kn, mu_r, overlap = 1e6, 0.1, 1e-3
    d = 2 * R - overlap
    c = contact(kn, np.ones(2), mu=0.3, rolling=mu_r)
    kr = 2.0 / 7.0 * kn * (R / 2) ** 2
    cap = mu_r * (R / 2) * kn * overlap
    a_cap = cap / kr / 2

    def turned(a, apart=d):
        out = np.zeros((2, 3))
        c.forces(np.array([[0.0, 0.0, a], [apart, 0.0, -a]]), np.zeros(0, bool), out, 2)
        return out

    lost = 0.0
    up, down = np.linspace(0.0, 3 * a_cap, 301), np.linspace(3 * a_cap, 2 * a_cap, 101)[1:]
    expected = np.concatenate([np.minimum(2 * kr * up, cap), cap - 2 * kr * (3 * a_cap - down)])
    for a, moment in zip(np.concatenate([up, down]), expected):
        out = turned(a)
        lost += c._slipped
        assert abs(out[1, 1]) < 1e-12 * kn * overlap                   # no shear
        assert out[0, 2] == pytest.approx(-out[1, 2], rel=1e-12)
        assert out[1, 2] == pytest.approx(moment, rel=1e-9, abs=1e-12 * cap)
    assert lost == pytest.approx(cap * 2 * (2 * a_cap), rel=1e-2)      # rolled 2 x 2 a_cap
    held = c.energy - 0.5 * kn * overlap ** 2
    assert held == pytest.approx(0.5 * (cap - 2 * kr * a_cap) ** 2 / kr, rel=1e-9)
    turned(2 * a_cap, apart=2 * R + 1e-3)                               # let go
    assert c._slipped == pytest.approx(held, rel=1e-9)


def test_a_pair_turning_rigidly_strains_no_shear_spring():
    """Two touching particles turned together about their midpoint by 1 rad
    in 2000 steps, each particle turning with them: the shear spring stays
    below 1e-4 of the normal force (measured 1.2e-5, the chords' departure
    from the arc: it rolls with the spins); held unturned, the same motion
    slides them at mu f_n, their torques -r/2 n x f_t alike."""
    kn = 1e6
    d = 2 * R - 1e-3
    for turn in (1.0, 0.0):
        c = contact(kn, np.ones(2), mu=0.3)
        for k in range(2001):
            a = k * 1.0 / 2000
            x = 0.5 * d * np.array([np.cos(a), np.sin(a)])
            q = np.array([[*-x, turn * a], [*x, turn * a]])
            f = np.zeros((2, 3))
            c.forces(q, np.zeros(0, bool), f, 2)
            n = x / np.linalg.norm(x)
            normal = abs(f[1, :2] @ n)
            shear = abs(f[1, 0] * n[1] - f[1, 1] * n[0])
        assert normal == pytest.approx(kn * 1e-3, rel=1e-9)
        if turn:
            assert shear < 1e-4 * normal and np.abs(f[:, 2]).max() < 1e-4 * normal * R
        else:
            assert shear == pytest.approx(0.3 * normal, rel=1e-9)
            assert f[0, 2] == pytest.approx(f[1, 2]) and abs(f[1, 2]) == \
                pytest.approx(0.5 * d * shear, rel=1e-9)


def cluster3(n=5, seed=3):
    """A jittered n^3 packing of rotating spheres (rotation vectors): positions
    and velocities with the three rotations last, masses per column."""
    X, v = jittered(n, 3, seed)
    rng = np.random.default_rng(seed)
    mass = rng.uniform(0.5, 2.0, len(X))
    inertia = 0.4 * mass * R ** 2
    q = np.column_stack([X, np.zeros((len(X), 3))])
    w = np.column_stack([v, rng.normal(0.0, 8.0, (len(X), 3))])
    return q, w, np.column_stack([mass, mass, mass, inertia, inertia, inertia])


@pytest.mark.parametrize("history, rolling, spread", [(True, 0.0, 0.0), (False, 0.0, 0.0),
                                                     (True, 0.1, 0.0), (True, 0.1, 0.2)])
def test_3d_compiled_loops_turn_spheres_as_the_numpy_path(history, rolling, spread):
    """3D (model.lattice.bond: beam on a solid): a jittered packing of 125
    spinning spheres stepped with velocity Verlet: the compiled loops'
    forces and torques (and rolling springs'), dashpot and friction forces
    and torques, energy, work of sliding and rolling and touching pairs equal
    the numpy path's (1e-12 of the largest) at every step through rebuilds,
    with one radius or radii spread by +-20 %; the torques matter."""
    q, w, m = cluster3()
    kn, h = 2e5, 0.02 / np.sqrt(2e5)
    radii = R * np.random.default_rng(9).uniform(1 - spread, 1 + spread, len(q)) \
        if spread else None
    args = dict(zeta=0.3, mu=0.2, zeta_t=0.3, history=history, h=h, rotary=3, rolling=rolling,
                radii=radii)
    compiled_equals_numpy(q, w, m, kn, 120, 3, **args)


def audit3(rolling=0.0, seed=5, steps=1500):
    """A free cluster of 125 spinning spheres (shear springs, friction 0.3,
    ``rolling`` mu_r) stepped by velocity Verlet: (the largest change of
    its angular momentum m x cross v + I omega over its scale, the largest
    energy audit error over the start's energy, the energy slid or rolled
    away over it)."""
    q, w, m = cluster3(seed=seed)
    kn = 2e5
    h = 0.05 / np.sqrt(kn)
    c = contact(kn, m[:, 0], mu=0.3, h=h, rotary=3, rolling=rolling)

    def angular(q, w):
        return np.sum(m[:, :1] * np.cross(q[:, :3], w[:, :3]) + m[:, 3:] * w[:, 3:], axis=0)
    start = contact(kn, m[:, 0], rotary=3)
    start.forces(q, np.zeros(0, bool), np.zeros_like(q), len(q))
    L0, E0 = angular(q, w), 0.5 * float(np.sum(m * w * w)) + start.energy
    scale = float(np.sum(m[:, 0] * np.linalg.norm(q[:, :3], axis=1) *
                         np.linalg.norm(w[:, :3], axis=1)))
    slid = drift = change = 0.0
    for q, w, got in verlet([c], q, w, m, h, steps, viscous=False):
        _, _, _, e, s, _ = got[0]
        slid += s
        drift = max(drift, abs(0.5 * float(np.sum(m * w * w)) + e + slid - E0) / E0)
        change = max(change, np.abs(angular(q, w) - L0).max() / scale)
    return change, drift, slid / E0


def test_3d_spheres_keep_angular_momentum_and_a_rigid_pair_strains_nothing():
    """A free cluster of 125 spinning spheres, shear springs sticking and
    sliding (14 % of the energy slides away): the angular momentum sum
    m x cross v + I omega (each component) is kept to 1e-12 of its scale
    (measured 8e-14), and the energy audit closes to 1e-2 (measured 7.5e-3,
    3.8e-3 at half the step: first order, as in 2D).  Two touching spheres
    turned together by 1 rad about a skew axis through their midpoint in
    2000 steps, each particle's rotation vector turning with them: the shear
    spring stays below 1e-4 of the normal force (measured 5.7e-6: the roll
    is taken about the mid separation; about the new one, 2e-2); held
    unturned, they slide at mu f_n, their torques alike."""
    change, drift, slid = audit3()
    assert slid > 0.02, slid
    assert change < 1e-12, change
    assert drift < 1e-2, drift

    kn = 2e5
    d = 2 * R - 1e-3
    axis = np.array([0.3, 0.4, np.sqrt(0.75)])                 # unit, skew to the pair
    from solver.partitions.beam_bond3d import rotations
    for turn in (1.0, 0.0):
        pair = contact(kn, np.ones(2), mu=0.3, rotary=3)
        for k in range(2001):
            a = k * 1.0 / 2000
            x = rotations((a * axis)[None])[0] @ np.array([0.5 * d, 0.0, 0.0])
            q2 = np.array([[*-x, *(turn * a * axis)], [*x, *(turn * a * axis)]])
            f = np.zeros((2, 6))
            pair.forces(q2, np.zeros(0, bool), f, 2)
        n = x / np.linalg.norm(x)
        normal = abs(f[1, :3] @ n)
        shear = np.linalg.norm(f[1, :3] - (f[1, :3] @ n) * n)
        assert normal == pytest.approx(kn * 1e-3, rel=1e-9)
        if turn:
            assert shear < 1e-4 * normal, shear / normal
        else:
            assert shear == pytest.approx(0.3 * normal, rel=1e-9)
            assert np.allclose(f[0, 3:], f[1, 3:]) and np.linalg.norm(f[1, 3:]) == \
                pytest.approx(0.5 * d * shear, rel=1e-9)


def test_a_3d_rolling_spring_rolls_across_the_normal_and_lets_twisting_go():
    """Two pressed spheres along a skew normal n, turned in opposite senses
    about an axis t across it (theta_0 = a t, theta_1 = -a t: one rolls on
    the other): the rolling spring's moment is k_r phi t on 1 and minus that
    on 0 (phi = 2a, k_r = k_t R*^2) up to mu_r R* f_n, then that cap, the
    shear spring unloaded; turned back, it unloads along k_r.  Twisted about
    n instead, nothing resists.  A free cluster of 125 spinning spheres with
    rolling resistance keeps its angular momentum (1e-12) and closes its
    audit (1e-2), the rolling springs' dissipation counted."""
    kn, mu_r, overlap = 1e6, 0.1, 1e-3
    n = np.array([0.3, 0.4, np.sqrt(0.75)])
    t = np.cross(n, [1.0, 0.0, 0.0])
    t /= np.linalg.norm(t)
    kr = 2.0 / 7.0 * kn * (R / 2) ** 2
    cap = mu_r * (R / 2) * kn * overlap
    a_cap = cap / kr / 2
    for axis, resists in ((t, True), (n, False)):
        c = contact(kn, np.ones(2), mu=0.3, rolling=mu_r, rotary=3)
        up, down = np.linspace(0.0, 3 * a_cap, 151), np.linspace(3 * a_cap, 2 * a_cap, 51)[1:]
        want = np.concatenate([np.minimum(2 * kr * up, cap), cap - 2 * kr * (3 * a_cap - down)])
        lost = 0.0
        for a, moment in zip(np.concatenate([up, down]), want):
            out = np.zeros((2, 6))
            q = np.array([[0.0, 0.0, 0.0, *(a * axis)], [*((2 * R - overlap) * n), *(-a * axis)]])
            c.forces(q, np.zeros(0, bool), out, 2)
            lost += c._slipped
            shear = out[1, :3] - (out[1, :3] @ n) * n
            assert np.abs(shear).max() < 1e-12 * kn * overlap
            assert np.abs(out[0, 3:] + out[1, 3:]).max() < 1e-12 * cap
            expect = moment * axis if resists else np.zeros(3)
            assert np.abs(out[1, 3:] - expect).max() < 1e-9 * cap + 1e-12 * cap, (a, out[1, 3:])
        if resists:
            assert lost == pytest.approx(cap * 2 * (2 * a_cap), rel=2e-2)    # rolled 2 x 2 a_cap
        else:
            assert lost == 0.0
    change, drift, slid = audit3(rolling=0.1)
    assert change < 1e-12 and drift < 1e-2 and slid > 0.02, (change, drift, slid)
