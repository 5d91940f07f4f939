"""Contact friction with memory (model.lattice.contact.friction_model:
history; solver/partitions/contact.py): the Cundall-Strack shear spring with
Coulomb sliding, its history kept by particle ids across rebuilds, ranks and
restarts (issue 25).  The energy audit of a crack closing on such contacts:
tests/test_bonds.py."""
from __future__ import annotations

import numpy as np
import pytest

R, K, MU, D = 1e-3, 2e7, 0.3, 1e-5          # radius, k_n, friction, overlap
RATIO = 2.0 / 7.0
M = np.array([2e-6, 6e-6])


def pair(ids=None, zeta_t=0.0, dt=1e-9, zeta=0.0):
    from solver.laws import CONTACT_LAWS, ContactSettings
    from solver.partitions.contact import Contact
    settings = ContactSettings(CONTACT_LAWS["linear"](K), R, 0.3 * R, zeta, MU, zeta_t,
                               history=True, tangential_stiffness=RATIO)
    return Contact(np.arange(2), settings, np.zeros(0, np.int64), np.zeros(0, np.int64), M,
                   ids=ids, dt=dt)


def force_on_1(c, x):
    out = np.zeros((2, 2))
    c.forces(x, np.zeros(0, bool), out, 2)
    assert np.array_equal(out[0], -out[1])              # equal and opposite
    return out[1]


UNIT, TANG = np.array([0.6, 0.8]), np.array([-0.8, 0.6])
RHO = 2 * R - D                          # the distance of the pressed pair


def at(s, rho=RHO):
    """Particle 1 pressed onto particle 0 (distance ``rho``), moved by the arc
    s around it (its shear displacement s)."""
    th = s / RHO
    c, sn = np.cos(th), np.sin(th)
    return np.array([[0.0, 0.0], rho * (c * UNIT + sn * TANG)])


def along(f, x):
    """The tangential component of force ``f`` on particle 1 at positions ``x``,
    along the direction of growing s."""
    n = x[1] / np.linalg.norm(x[1])
    return float(np.dot(f, [-n[1], n[0]]))


def test_the_shear_spring_sticks_then_slides_and_unloads_elastically():
    """Moving particle 1 around particle 0 at a constant overlap in small
    steps: the tangential force is -k_t s while k_t s < mu f_n (the stored
    shear turned into each new tangent plane), then mu f_n (sliding: the
    energy the cap takes from the spring is dissipated, mu f_n x slip plus
    1/2 k_t ds^2 per step of ds, which vanishes as the steps shrink); moving
    back unloads along k_t (hysteresis)."""
    c = pair()
    kt, cap = RATIO * K, MU * K * D
    s_stick = cap / kt
    path = np.concatenate([np.linspace(0, 3 * s_stick, 61),
                           np.linspace(3 * s_stick, 2 * s_stick, 21)[1:]])
    slipped = 0.0
    for n, s in enumerate(path):
        x = at(s)
        f = force_on_1(c, x)
        slipped += c._slipped
        if n <= 20:                                          # s <= s_stick: sticking
            assert abs(along(f, x) + kt * s) < 1e-6 * cap, n
        elif n <= 60:                                        # sliding at mu f_n
            assert abs(along(f, x) + cap) < 1e-6 * cap, n
        else:                                                # back by b: mu f_n - k_t b
            b = 3 * s_stick - s
            assert abs(along(f, x) + cap - kt * b) < 1e-6 * cap, n
        assert abs(np.dot(f, x[1]) / RHO - K * D) < 1e-9 * K * D       # the normal force
    ds = 3 * s_stick / 60
    want = cap * 2 * s_stick + 40 * 0.5 * kt * ds ** 2
    assert abs(slipped / want - 1) < 1e-6                    # (chords, not arcs: 1e-8)
    b = s_stick
    assert abs(c.energy - 0.5 * K * D ** 2 - 0.5 * (cap - kt * b) ** 2 / kt) < 1e-9 * c.energy


def test_the_cap_follows_the_normal_force():
    """Sticking at half the Coulomb limit: pressing harder keeps the shear
    force (no tangential motion); unloading to a quarter of the overlap
    lowers the limit below it, and the contact slides to mu f_n."""
    c = pair()
    kt, cap = RATIO * K, MU * K * D
    s = 0.5 * cap / kt
    force_on_1(c, at(0.0))
    x = at(s)                                          # (one chord: 1e-6 of the arc)
    assert abs(along(force_on_1(c, x), x) + 0.5 * cap) < 1e-5 * cap
    x = at(s, 2 * R - 2 * D)
    assert abs(along(force_on_1(c, x), x) + 0.5 * cap) < 1e-5 * cap
    x = at(s, 2 * R - 0.25 * D)
    assert abs(along(force_on_1(c, x), x) + 0.25 * cap) < 1e-9 * cap
    assert c._slipped > 0


@pytest.mark.parametrize("compiled", [True, False])
def test_the_energy_a_spring_loses_is_dissipated(compiled):
    """A spring stuck at 0.8 mu f_n: unloading the overlap to a quarter in one
    step lowers the cap below it, and the energy the cap takes, 1/2 k_t
    (xi^2 - (mu f_n' / k_t)^2), is dissipated; pulling the pair apart lets
    the spring go and dissipates its last 1/2 k_t xi^2 (both paths)."""
    from solver.laws import CONTACT_LAWS, ContactSettings
    from solver.partitions.contact import Contact
    settings = ContactSettings(CONTACT_LAWS["linear"](K), R, 0.3 * R, 0.0, MU, 0.0,
                               history=True, tangential_stiffness=RATIO)
    c = Contact(np.arange(2), settings, np.zeros(0, np.int64), np.zeros(0, np.int64), M,
                dt=1e-9, compiled=compiled)
    kt, cap = RATIO * K, MU * K * D
    xi = 0.8 * cap / kt
    for n in range(9):
        force_on_1(c, at(xi * n / 8))
    assert c._slipped == 0.0
    x = at(xi, 2 * R - 0.25 * D)
    force_on_1(c, x)
    left = 0.25 * cap / kt
    assert abs(c._slipped - 0.5 * kt * (xi ** 2 - left ** 2)) < 1e-5 * c._slipped
    force_on_1(c, at(xi, 2 * R + 0.1 * D))                   # apart
    assert abs(c._slipped - 0.5 * kt * left ** 2) < 1e-5 * c._slipped
    assert c.energy == 0.0 and len(c.touching()[0]) == 0


def test_a_piece_without_contacts_checkpoints_an_empty_history(tmp_path):
    """The closing-crack lattice with shear springs at the default radius:
    nothing touches at rest, and the checkpoint's history is an empty table
    of the right width (it once failed to reshape)."""
    from test_bonds import dem_of, nonlinear
    raw = nonlinear(time__dt=5e-9, time__end=7.5e-5)
    raw["model"]["lattice"]["contact"] = {"stiffness": 1.68e7, "friction": 0.3,
                                          "friction_model": "history"}
    asm, dem = dem_of(raw, tmp_path)
    rows = dem.force.contact_history()
    assert rows.shape == (0, 2 + 2 * 2)
    asm.destroy()


@pytest.mark.parametrize("swap", [False, True])
def test_the_history_survives_a_rebuild_and_a_renumbering(swap):
    """Rebuilding the search mid-way, with the particles' local order swapped
    (their global ids kept), gives the forces of the run without a rebuild,
    bitwise: the history is keyed and oriented by global ids."""
    ref, c = pair(), pair()
    s_path = np.concatenate([np.linspace(0, 2 * MU * D / RATIO, 30),
                             np.linspace(2 * MU * D / RATIO, 0, 10)])
    for n, s in enumerate(s_path):
        f_ref = force_on_1(ref, at(s))
        x = at(s)
        if n == 12:
            if swap:                                   # particle 1 becomes local index 0
                c.renew(np.arange(2), M[::-1], None, ids=np.array([1, 0]))
            else:
                c.renew(np.arange(2), M, None)
        if n >= 12 and swap:
            out = np.zeros((2, 2))
            c.forces(x[::-1], np.zeros(0, bool), out, 2)
            f = out[0]
        else:
            f = force_on_1(c, x)
        assert np.array_equal(f, f_ref), n


def test_the_dashpot_beside_the_spring_and_the_work_of_sliding():
    """Sticking: the tangential dashpot c_t = 2 zeta_t sqrt(k_t m*) opposes
    the sliding velocity, limited so that spring and dashpot stay within
    mu f_n; sliding: no dashpot, and viscous() reports the work of sliding
    over the step as a power."""
    dt = 1e-8
    c = pair(zeta_t=0.5, dt=dt)
    kt, cap = RATIO * K, MU * K * D
    force_on_1(c, at(0.0))
    x = at(0.2 * cap / kt)
    force_on_1(c, x)                                    # sticking at 0.2 mu f_n
    n = x[1] / RHO
    tang = np.array([-n[1], n[0]])                      # the tangent there
    w = 1e-3
    out = np.zeros((2, 2))
    power = c.viscous(np.array([[0.0, 0.0], w * tang]), out, 2)
    ct = 2 * 0.5 * np.sqrt(kt * M[0] * M[1] / M.sum())
    assert ct * w < 0.8 * cap
    assert np.allclose(out[1], -ct * w * tang, rtol=1e-9) and np.allclose(out[0], -out[1])
    assert abs(power / (ct * w ** 2) - 1) < 1e-12
    out[:] = 0
    big = 100.0                                          # the dashpot alone would exceed the room
    c.viscous(np.array([[0.0, 0.0], big * tang]), out, 2)
    assert abs(np.linalg.norm(out[1]) - 0.8 * cap) < 1e-6 * cap
    force_on_1(c, at(1.5 * cap / kt))                   # sliding: the spring at mu f_n
    slip = c._slipped                                   # what the cap took: 1/2 k_t (1.5^2 - 1)
    assert abs(slip - 0.625 * cap ** 2 / kt) < 1e-4 * slip         # (one chord)
    out[:] = 0
    power = c.viscous(np.array([[0.0, 0.0], w * tang]), out, 2)
    assert np.allclose(out, 0.0) and abs(power - slip / dt) < 1e-9 * power


@pytest.mark.parametrize("push, sticks", [(0.8, True), (1.5, False)])
def test_static_friction_holds_a_load_below_mu_n(push, sticks):
    """A particle pressed onto a fixed one by N and pushed sideways by F =
    push x mu N, stepped with velocity Verlet (normal and tangential
    dashpots): below mu N it comes to rest at F / k_t (static friction: the
    viscous law creeps instead), above it slides off with acceleration
    (F - mu N) / m."""
    from solver.laws import CONTACT_LAWS, ContactSettings
    from solver.partitions.contact import Contact
    m = np.array([1e30, 1e-6])                  # particle 0 held (not stepped)
    N = 10.0
    settings = ContactSettings(CONTACT_LAWS["linear"](K), R, 0.3 * R, 0.7, MU, 0.7,
                               history=True, tangential_stiffness=RATIO)
    h = 0.05 * np.sqrt(1e-6 / K)
    c = Contact(np.arange(2), settings, np.zeros(0, np.int64), np.zeros(0, np.int64), m, dt=h)
    F = push * MU * N
    load = np.array([F, -N])
    x = np.array([[0.0, 0.0], [0.0, 2 * R - N / K]])
    v, a = np.zeros((2, 2)), np.zeros((2, 2))
    T = (400 if sticks else 15) * np.sqrt(1e-6 / K)     # sliding: to 0.01 R
    steps = int(T / h)
    half = None
    for step in range(steps):
        x[1] += h * v[1] + 0.5 * h * h * a[1]
        v[1] += 0.5 * h * a[1]
        out = np.zeros((2, 2))
        c.forces(x, np.zeros(0, bool), out, 2)
        c.viscous(v, out, 2)
        a[1] = (out[1] + load) / m[1]
        v[1] += 0.5 * h * a[1]
        if step == steps // 2:
            half = v[1, 0]
    if sticks:
        assert abs(x[1, 0] / (F / (RATIO * K)) - 1) < 0.02
        assert abs(v[1, 0]) < 1e-3 * F / np.sqrt(K * 1e-6)
    else:                                    # the acceleration over the second half
        assert abs((v[1, 0] - half) / (0.5 * T) / ((F - MU * N) / m[1]) - 1) < 0.03


@pytest.mark.parametrize("n, n_restart", [(None, None), (2, 2), (2, 1)])
def test_a_run_with_shear_histories_restarts_to_the_uninterrupted_run(tmp_path, n, n_restart):
    """tests/test_contact_halo.py's bar, whose contacts stick and slide
    (friction 0.02 on shear springs): SIGTERMed after its 9th checkpoint and
    restarted, it ends as the uninterrupted run did: bitwise on the same
    rank count, 1 or 2 (on 2, the dissipated energy to an ulp; the
    checkpoint keeps every contact's shear displacement and last separation,
    by particle ids, each counted by one piece, also in the checkpoint
    written right after the restart; the
    restart builds the search anew, and the sorted pairs sum the forces in
    the same order), and every history to 1e-13 of its largest value when a
    2-rank run restarts on 1 (the pieces' sums differ in order)."""
    from test_checkpoints import assert_same, interrupted_then_restarted
    from test_contact_halo import halo_bar
    raw = halo_bar(tmp_path, "bar", "history")
    whole, again = interrupted_then_restarted(raw, tmp_path, raw["time"]["end"], n=n,
                                              n_restart=n_restart)
    assert whole["energy/dissipated"][-1] > 0.1 * whole["energy/external_work"][-1]
    if n == n_restart:
        if n is None:
            assert_same(whole, again)
            return
        # a split partition's dissipation sum restarts on its first piece, so the
        # later sums associate differently: that one history to an ulp
        d = "energy/dissipated"
        assert np.abs(whole[d] - again[d]).max() <= 1e-15 * np.abs(whole[d]).max()
        assert_same({k: v for k, v in whole.items() if k != d},
                    {k: v for k, v in again.items() if k != d})
        return
    assert set(whole) == set(again) and again["status"] == "completed"
    for key, x in whole.items():
        if np.asarray(x).dtype.kind == "f":
            scale = np.abs(x).max()
            assert np.abs(x - again[key]).max() <= 1e-13 * scale, key


@pytest.mark.parametrize("sets, message", [
    ({"friction_model": "history"},
     "model.lattice.contact.friction_model: history is the sticking and sliding of friction: "
     "give friction > 0"),
    ({"friction": 0.3, "tangential_damping_ratio": 0.0},
     "model.lattice.contact.tangential_damping_ratio: friction_model viscous needs it > 0"),
    ({"friction": 0.3, "friction_model": "memory"}, "model.lattice.contact.friction_model"),
    ({"friction": 0.3, "friction_model": "history", "tangential_stiffness": 0.0},
     "model.lattice.contact.tangential_stiffness"),
])
def test_bad_friction_input_is_one_line(sets, message, tmp_path):
    """Exit 2, one line naming the key, no output file."""
    from conftest import refused, write_scene
    from test_bonds import nonlinear
    raw = nonlinear()
    raw["model"]["lattice"]["contact"] = {"stiffness": 1.68e7, **sets}
    line = refused(write_scene(tmp_path / "bad.yaml", raw), [], tmp_path)
    assert message in line, line


def jittered(n, dim, seed=1):
    """n^dim particles of radius 0.5 on a jittered grid of spacing 0.95: about
    one contact per neighbour, random velocities."""
    rng = np.random.default_rng(seed)
    g = np.arange(n) * 0.95
    X = np.stack(np.meshgrid(*([g] * dim), indexing="ij"), -1).reshape(-1, dim)
    return X + rng.uniform(-0.04, 0.04, X.shape), rng.normal(0.0, 2.0, X.shape)


@pytest.mark.parametrize("dim, law, model", [(2, "linear", "history"), (3, "hertz", "history"),
                                             (3, "linear", "viscous")])
def test_the_compiled_loops_match_the_numpy_reference(dim, law, model):
    """A jittered packing stepped with velocity Verlet: at every step the
    compiled loops' contact forces, dashpot and friction forces, energy,
    work of sliding and touching pairs equal the numpy path's (forces to
    1e-12 of the largest), through search rebuilds; contacts slide."""
    from solver.laws import CONTACT_LAWS, ContactSettings
    from solver.partitions.contact import Contact
    X, v = jittered(12 if dim == 2 else 6, dim)
    N = len(X)
    mass = np.ones(N)
    kn = 2e5 if law == "linear" else 2e6
    settings = ContactSettings(CONTACT_LAWS[law](kn), 0.5, 0.1, 0.3, 0.2, 0.3,
                               history=model == "history")
    h = 0.02 / np.sqrt(kn)
    args = (np.arange(N), settings, np.zeros(0, np.int64), np.zeros(0, np.int64), mass)
    fast, ref = Contact(*args, dt=h), Contact(*args, dt=h, compiled=False)
    assert fast.compiled and not ref.compiled
    x, a, alive = X.copy(), np.zeros_like(X), np.zeros(0, bool)
    slid = 0.0
    for step in range(150):
        x += h * v + 0.5 * h * h * a
        v += 0.5 * h * a
        out = []
        for c in (fast, ref):
            f = np.zeros_like(X)
            c.forces(x, alive, f, N)
            g = np.zeros_like(X)
            power = c.viscous(v, g, N)
            out.append((f, g, power, c.energy, c._slipped, c.touching()))
        (f, g, p, e, s, t), (f0, g0, p0, e0, s0, t0) = out
        scale = np.abs(f0).max()
        assert np.abs(f - f0).max() <= 1e-12 * scale and np.abs(g - g0).max() <= 1e-12 * scale
        assert abs(p - p0) <= 1e-12 * abs(p0) and abs(e - e0) <= 1e-12 * e0
        assert abs(s - s0) <= 1e-12 * max(s0, 1e-300)
        assert np.array_equal(t[0], t0[0]) and np.array_equal(t[1], t0[1])
        slid += s
        a = f0 + g0
        v += 0.5 * h * a
    assert fast.builds == ref.builds > 1
    assert (slid > 0) == (model == "history")


@pytest.mark.parametrize("dim, n, reach, spread", [(2, 2000, 0.7, 10.0), (3, 3000, 0.9, 5.0),
                                                   (3, 500, 0.2, 1e3)])
def test_the_cell_list_finds_the_pairs_of_the_k_d_tree(dim, n, reach, spread):
    """The compiled search (cells of side >= reach; a far cluster makes the
    grid sparse and its cells larger) returns exactly scipy's query_pairs,
    sorted by first then second point."""
    from scipy.spatial import cKDTree
    from solver.partitions.contact_kernel import pairs_within
    rng = np.random.default_rng(dim + n)
    x = rng.uniform(0.0, 1.0, (n, dim)) * (spread if spread < 100 else 1.0)
    if spread >= 100:
        x[-10:] += spread
    got = pairs_within(x, reach)
    want = cKDTree(x).query_pairs(reach, output_type="ndarray")
    want = want[np.lexsort((want[:, 1], want[:, 0]))]
    assert len(want) > n and np.array_equal(got, want)


def test_contact_leaves_the_fem_sides_lattice_sites_out(tmp_path):
    """configs/bar3d.yaml (an overlap between hexahedra and a cubic lattice)
    with nonlinear bonds and contact at the default radius, compressed by its
    pulse: the dem particles next to the fem-owned lattice sites of the
    overlap share no bond with them and once pushed on them through contact,
    a force the fem side never felt (the audit missed 6e-3 of the work).
    Those sites take no part in contact: no pair touches, and the audit
    closes as without contact (1.8e-4), the same trajectory."""
    from conftest import raw_scene, run_scene
    runs = {}
    for name, contact in (("plain", None), ("contact", {"stiffness": 5.0e6})):
        raw = raw_scene("bar3d")
        raw["model"]["lattice"]["geometry"] = "nonlinear"
        if contact:
            raw["model"]["lattice"]["contact"] = contact
        raw["time"]["end"] = 1.2e-5
        raw["output"] = {"file": str(tmp_path / f"{name}.h5"), "energy_every": 1}
        runs[name] = run_scene(raw, tmp_path)
    res = runs["contact"]
    assert res.partitions["dem"]["contact_pairs"] == 0
    e = res.energy
    work = e["external_work"][-1]
    assert abs(e["total"][-1] + e["dissipated"][-1] - work) < 1e-3 * work
    for p in ("D", "F"):
        assert np.array_equal(res.probes[p]["displacement"], runs["plain"].probes[p]["displacement"])
