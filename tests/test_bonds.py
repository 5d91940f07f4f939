"""Lattice bonds from the current configuration, and their breakage
(solver/partitions/bonds.py; issue 10's first part)."""
from __future__ import annotations

import h5py
import numpy as np
import pytest

from conftest import raw_scene, refused, run_cli, run_scene, stop_and_restart, write_scene

C = np.sqrt(70e9 / 2700.0)


def nonlinear(**over):
    raw = raw_scene("wave_bar_transition")
    raw["model"]["lattice"]["geometry"] = "nonlinear"
    for key, value in over.items():
        node = raw
        *head, last = key.split("__")
        for k in head:
            node = node[k] if not k.isdigit() else node[int(k)]
        node[last] = value
    return raw


def dem_of(raw, tmp_path):
    from mpi4py import MPI

    from solver import scene as scene_mod
    from solver.driver.build import build
    from solver.model import binding
    from solver.petscutil import init
    init([])
    raw = dict(raw, output={"file": str(tmp_path / "b.h5")})
    asm = build(binding.bind(scene_mod.from_dict(raw)), MPI.COMM_SELF)
    return asm, next(p for p in asm.parts if p.method == "dem")


def lattice_force(dem, U):
    """The lattice bonds' part of the dem force at displacement U (held DOFs)."""
    dem.U[:] = U
    dem.force.internal(dem.u, dem.r)
    total = dem.R.copy()
    dem.force.operator.mult(dem.u, dem.r)          # the linear elements (carried bonds)
    return total - dem.R


def test_a_large_rigid_rotation_exerts_no_force(tmp_path):
    """A 90-degree rotation of every particle: the nonlinear bonds exert nothing
    (1e-9 of one bond's k a), the small-strain operator a force of order k a."""
    asm, dem = dem_of(nonlinear(), tmp_path)
    X = dem.force.X[:dem.force.n_held]
    centre = X.mean(axis=0)
    R = np.array([[0.0, -1.0], [1.0, 0.0]])
    U = ((X - centre) @ R.T + centre - X).ravel()
    f = lattice_force(dem, U)
    scale = dem.force.k.max() * 2e-4
    assert np.abs(f[:2 * dem.n_own]).max() < 1e-9 * scale
    dem.force.tangent().mult(dem.u, dem.r)
    assert np.abs(dem.R[:2 * dem.n_own]).max() > 0.1 * scale
    asm.destroy()


def test_small_strains_agree_with_the_linear_operator(tmp_path):
    """A uniform stretch of 1e-6 plus shear: nonlinear bonds = the small-strain
    lattice operator to 1e-5 relative (second order in the strain)."""
    asm, dem = dem_of(nonlinear(), tmp_path)
    X = dem.force.X[:dem.force.n_held]
    eps = 1e-6
    U = np.stack([eps * X[:, 0] + 0.5 * eps * X[:, 1], -0.3 * eps * X[:, 1]], 1).ravel()
    f = lattice_force(dem, U)
    # the same through the linear lattice bonds alone: tangent minus the other elements
    dem.force.tangent().mult(dem.u, dem.r)
    lin = dem.R.copy()
    dem.force.operator.mult(dem.u, dem.r)
    lin -= dem.R
    n = 2 * dem.n_own
    assert np.abs(f[:n] - lin[:n]).max() < 1e-5 * np.abs(lin[:n]).max()
    asm.destroy()


def tension(tmp_path):
    """A tension pulse through the bar at FE step = DE step (no damping needed):
    the x-bonds at the DEM region's first column break as it arrives."""
    raw = nonlinear(model__lattice__break_strain=3e-4, partitions__0__ratio=1,
                    damping__beta=0.0)
    raw["loads"][0]["direction"] = [-1.0, 0.0]
    raw["time"]["end"] = 3.3992e-5                # 2428 steps; the breaks start at 31.7 us
    return run_scene(raw, tmp_path)


def test_bonds_break_when_the_tension_pulse_arrives_and_the_energy_adds_up(tmp_path):
    res = tension(tmp_path)
    broken = res.broken
    assert broken.shape[1] == 8 and len(broken) == res.partitions["dem"]["bonds_broken"] > 0
    t, x, strain = broken[:, 0], broken[:, 1], broken[:, 3]
    assert np.all(broken[:, 4] == 3e-4) and np.all(np.isnan(broken[:, 5]))   # limit; no heat
    assert np.all(strain > 3e-4) and np.all(strain < 3.2e-4)      # caught within a step
    # the first ones break where the pulse enters the core, when it gets there
    # (its front, smeared over the coarse cells, reaches 2/3 of the plateau)
    first = np.argmin(t)
    assert abs(t[first] - x[first] / C) < 0.03 * x[first] / C
    assert np.all(x < 0.1625) and np.all(x > 0.1575)
    e = res.energy
    released = res.partitions["dem"]["released_energy"]
    work = e["external_work"][-1]
    assert released > 0      # each bond's energy at its break: the mean of its last two
    # evaluations' (measured 4.0e-5; 2.2e-4 with the later one's alone)
    assert abs(e["total"][-1] + released - work) < 1e-4 * work


def test_the_energy_audit_of_a_damped_breaking_run_closes(tmp_path):
    """The same pulse with Rayleigh damping (alpha 2e4 1/s, beta 5e-9 s): kinetic +
    strain + released + dissipated = external work to 1.5e-4 of the work
    (measured 9.7e-5; 2.0e-4 when a broken bond released its later energy
    alone), with the dissipation a sizeable share (the audit would miss it
    by > 1 %)."""
    raw = nonlinear(model__lattice__break_strain=3e-4, partitions__0__ratio=1,
                    damping__beta=5e-9, damping__alpha=2e4)
    raw["loads"][0]["direction"] = [-1.0, 0.0]
    raw["time"]["end"] = 3.3992e-5                # 2428 steps of 1.4e-8 s
    res = run_scene(raw, tmp_path)
    e = res.energy
    released = res.partitions["dem"]["released_energy"]
    work = e["external_work"][-1]
    assert released > 0 and e["dissipated"][-1] > 0.01 * work
    assert abs(e["total"][-1] + released + e["dissipated"][-1] - work) < 1.5e-4 * work


def closing_crack_cli(tmp_path, n, dem_ranks=None):
    """The closing crack (tension, then compression) with a spring-dashpot
    contact, to 70 us, through the CLI on n ranks: (broken bonds sorted, t,
    displacements at A, B, C, stress at B)."""
    raw = nonlinear(model__lattice__break_strain=3e-4, partitions__0__ratio=1,
                    damping__beta=2e-9)
    raw["model"]["lattice"]["contact"] = {"stiffness": 1.68e7, "damping_ratio": 0.5}
    raw["time"]["end"] = 7.0e-5                   # B feels the closed crack from 65 us
    raw["reference"] = "none"
    raw["loads"] = [dict(raw["loads"][0], direction=[-1.0, 0.0]),
                    dict(raw["loads"][0], start=2.0e-5, duration=3.0e-5)]
    if dem_ranks:                                # the fem partition rides on rank 0
        raw["partitions"][1]["ranks"] = dem_ranks
    raw["output"] = {"file": str(tmp_path / f"c{n}.h5"), "progress": 0}
    proc = run_cli([write_scene(tmp_path / f"c{n}.yaml", raw)], n=n if n > 1 else None,
                   timeout=400)
    assert proc.returncode == 0, proc.stderr
    with h5py.File(tmp_path / f"c{n}.h5") as f:
        b = f["broken_bonds"][()]
        return (b[np.lexsort((b[:, 7], b[:, 6], b[:, 0]))], f["probes/A/t"][()],
                *(f[f"probes/{p}/displacement"][()] for p in "ABC"), f["probes/B/stress"][()])


def test_breakage_and_contact_on_one_and_two_ranks_agree(tmp_path):
    """The dem partition split over two ranks (ghost particles by VecScatter,
    contact through the halo), the fem partition riding on rank 0 (given
    ranks leave none for it): a tension pulse breaks the
    core's first column, a compression pulse closes the crack through the
    spring-dashpot contacts.  The same bonds break at the same system steps
    (where and at what strain to 1e-12); the histories agree to 1e-12 of the
    peak displacement until the first break and to 1e-9 after it."""
    one = closing_crack_cli(tmp_path, 1)
    three = closing_crack_cli(tmp_path, 2, dem_ranks=2)
    assert one[0].shape == three[0].shape and len(one[0]) >= 37
    a, b = one[0], three[0]
    assert np.array_equal(a[:, [0, 4, 6, 7]], b[:, [0, 4, 6, 7]])   # which bonds, when
    assert np.abs(a[:, 1:4] - b[:, 1:4]).max() <= 1e-12 * np.abs(a[:, 1:4]).max()
    t = one[1]
    before = t < a[:, 0].min()
    scale = max(np.abs(h).max() for h in one[2:5])                 # the peak displacement
    for x, y in zip(one[2:5], three[2:5]):
        assert np.abs(x - y)[before].max() <= 1e-12 * scale       # until the first break
        assert np.abs(x - y).max() <= 1e-9 * scale                 # and after it
    sb = one[5]
    assert sb.min() < -0.8 * 1.0e4 / 3.2e-4                         # B compressed through the crack
    assert np.abs(sb - three[5]).max() <= 1e-9 * np.abs(sb).max()


@pytest.mark.parametrize("sets,message", [
    (["model.lattice.geometry=linear", "model.lattice.break_strain=1e-3"],
     "model.lattice.break_strain: needs geometry: nonlinear"),
    (["model.lattice.geometry=nonlinear", "model.lattice.break_strain=-1e-3"],
     "model.lattice.break_strain"),
])
def test_bad_bond_input(sets, message, tmp_path):
    line = refused("configs/wave_bar_transition.yaml", sets, tmp_path)
    assert message in line, line


def test_a_run_with_broken_bonds_restarts_to_the_same_breaks(tmp_path):
    """Checkpoints keep the broken bonds: a run stopped after the first breaks
    and continued to a later end breaks the same bonds at the same times and
    has the same histories, bitwise, as one run."""
    raw = nonlinear(model__lattice__break_strain=3e-4, partitions__0__ratio=1,
                    damping__beta=0.0)
    raw["loads"][0]["direction"] = [-1.0, 0.0]

    def some_broke(path):
        with h5py.File(path) as f:
            assert 0 < len(f["broken_bonds"]) < 37                # some broke before the stop
    out = {}
    for name, path in zip(("whole", "short"), stop_and_restart(
            raw, tmp_path, 3.36e-5, 3.1724e-5, 100, before=some_broke)):   # 2400, 2266 steps
        with h5py.File(path) as f:
            out[name] = (f["broken_bonds"][()], f["probes/B/displacement"][()],
                         f["partitions/dem"].attrs["bonds_broken"])
    assert np.array_equal(out["whole"][0], out["short"][0], equal_nan=True)
    assert np.array_equal(out["whole"][1], out["short"][1])
    assert out["whole"][2] == out["short"][2] == 37


def crack(contact, tmp_path):
    """A tension pulse breaks the DEM core's first column (a crack opens), then a
    compression pulse arrives: with contact the crack closes and transmits it."""
    raw = nonlinear(model__lattice__break_strain=3e-4, partitions__0__ratio=1,
                    damping__beta=2e-9)
    raw["model"]["lattice"]["contact"] = contact
    raw["time"]["end"] = 8.9992e-5                # 6428 steps of 1.4e-8 s
    raw["reference"] = "none"
    raw["loads"] = [dict(raw["loads"][0], direction=[-1.0, 0.0]),
                    dict(raw["loads"][0], start=2.0e-5, duration=3.0e-5)]
    return run_scene(raw, tmp_path)


def test_a_closing_crack_transmits_compression_only_with_contact(tmp_path):
    sigma = 1.0e4 / 3.2e-4                                     # the pulses' stress, 31.25 MPa
    late = {}
    for name, contact in (("apart", None), ("contact", {"stiffness": 1.68e7})):
        res = crack(contact, tmp_path)
        t, s = res.probes["C"]["t"], res.probes["C"]["stress"]
        late[name] = s[t > 7.0e-5].min()
        assert res.partitions["dem"]["bonds_broken"] >= 37        # the first column, at least
    assert late["apart"] > -0.2 * sigma                           # the open crack stops it
    assert late["contact"] < -0.8 * sigma                         # the closed crack passes it


def test_contact_raises_the_dem_critical_step_bound(tmp_path):
    """The guard adds 2 z k_n / m_min to the bonds' lambda_max (z = 6 in 2D)."""
    from solver.partitions.contact import coordination
    plain = dem_of(nonlinear(), tmp_path)
    with_c = dem_of(nonlinear(model__lattice__contact={"stiffness": 1.68e7},
                              time__dt=5e-9, time__end=7.5e-5), tmp_path)   # 3750 steps
    w0 = plain[0].scheme.freqs["dem"][0].omega_max
    w1 = with_c[0].scheme.freqs["dem"][0].omega_max
    m_min = with_c[1].mass[:with_c[1].n_own].min()
    assert abs(w1 ** 2 - w0 ** 2 - 2 * coordination(2) * 1.68e7 / m_min) < 1e-9 * w1 ** 2
    assert "contact bound" in with_c[0].scheme.freqs["dem"][0].method
    plain[0].destroy()
    with_c[0].destroy()


def test_contact_input_is_checked(tmp_path):
    out = tmp_path / "o.h5"
    proc = run_cli(["configs/wave_bar_transition.yaml", "--set", f"output.file={out}",
                    "--set", "model.lattice.contact={stiffness: 1.0e7}"])
    assert proc.returncode == 2
    assert "model.lattice.contact: needs geometry: nonlinear" in proc.stderr


def test_particle_fields_show_the_damage(tmp_path):
    """With breakable bonds the particle XDMF carries each particle's lost-bond
    fraction: 0 away from the crack, > 0 on both of its faces, never above 1."""
    import meshio
    raw = nonlinear(model__lattice__break_strain=3e-4, partitions__0__ratio=1,
                    damping__beta=0.0)
    raw["loads"][0]["direction"] = [-1.0, 0.0]
    raw["time"]["end"] = 3.3992e-5                # 2428 steps of 1.4e-8 s
    raw["output"] = {"file": str(tmp_path / "d.h5"), "fields": {"every": 800}, "progress": 0}
    proc = run_cli([write_scene(tmp_path / "d.yaml", raw)])
    assert proc.returncode == 0, proc.stderr
    with meshio.xdmf.TimeSeriesReader(str(tmp_path / "d_particles.xdmf")) as r:
        points, _ = r.read_points_cells()
        _, data, _ = r.read_data(r.num_steps - 1)
    damage = data["damage"]
    assert damage.min() == 0 and 0 < damage.max() <= 1
    cracked = points[damage > 0][:, 0]
    assert cracked.min() >= 0.1588 and cracked.max() <= 0.1594    # the first core columns


def test_particle_stress_follows_the_current_bonds(tmp_path):
    """Probe stress of a particle with nonlinear bonds: on an unbroken lattice
    it is the small-strain bond stress to second order (4.5e-4 relative at a
    strain of 4.5e-4); on a crack face it cannot exceed what the bonds hold
    before they break (9/8 E x break strain) and falls once they have."""
    lin = run_scene(raw_scene("wave_bar_transition"), tmp_path)
    non = run_scene(nonlinear(), tmp_path)
    s_lin, s_non = lin.probes["B"]["stress"], non.probes["B"]["stress"]
    assert np.abs(s_non - s_lin).max() < 1e-3 * np.abs(s_lin).max()
    raw = nonlinear(model__lattice__break_strain=3e-4, partitions__0__ratio=1,
                    damping__beta=0.0)
    raw["loads"][0]["direction"] = [-1.0, 0.0]
    raw["time"]["end"] = 4.4996e-5                # 3214 steps of 1.4e-8 s
    raw["reference"] = "none"
    raw["probes"] = [{"name": "F", "at": [0.159, 0.0012]}]          # on the crack's face
    res = run_scene(raw, tmp_path)
    t, s = res.probes["F"]["t"], res.probes["F"]["stress"]
    held = 9 / 8 * 70e9 * 3e-4
    assert 0.8 * held < s.max() < 1.1 * held
    assert np.abs(s[t > 3.3e-5]).max() < 0.3 * s.max()


@pytest.mark.parametrize("bond", ["central", "beam"])
def test_stiffness_proportional_damping_leaves_broken_bonds_out(bond, tmp_path):
    """Rayleigh damping of a breakable lattice at rest with random
    velocities, a third of its bonds broken: the residual is -beta (K0 - sum
    of the broken bonds' K_b) v - alpha M v to 1e-12 (K_b each broken bond's
    stiffness at rest, from its rest direction: k n n^T on the relative
    velocity; beams: their 6 x 6 block), so a crack's faces are not damped
    as if bonded; the dissipated power is v.C v of that C."""
    raw = nonlinear(model__lattice__break_strain=1.0, damping__beta=5e-9, damping__alpha=2e4)
    if bond == "beam":
        raw["model"]["material"]["nu"] = 0.25
        raw["model"]["lattice"].update(kind="random", bond="beam")
    raw["loads"] = []
    raw.pop("reference", None)
    asm, dem = dem_of(raw, tmp_path)
    f = dem.force
    rng = np.random.default_rng(5)
    gone = rng.random(len(f.k)) < 0.33
    f.alive[gone] = False
    dem.U[:] = 0.0
    dem.V[:] = rng.standard_normal(dem.V.size)
    dem.residual(0.0, dem.u, dem.v)
    got = dem.R.copy()
    f.alive[:] = True                                            # the same with K0 whole
    dem.residual(0.0, dem.u, dem.v)
    whole = dem.R.copy()
    dof, n = f.dim, f.n_held
    v = dem.V.reshape(n, dof)
    back = np.zeros((n, dof))                                    # beta sum K_b v, by hand
    for b in np.flatnonzero(gone):
        i, j = f.i[b], f.j[b]
        if bond == "central":
            unit = f.dX[b] / np.linalg.norm(f.dX[b])
            pull = f.k[b] * unit * np.dot(unit, v[j] - v[i])    # -K_b v on i
            back[i] -= pull
            back[j] += pull
        else:
            Ke = f._rest_blocks[f._source[[b]]][0]
            fe = Ke @ np.concatenate([v[i], v[j]])
            back[i] += fe[:dof]
            back[j] += fe[dof:]
    expected = whole + 5e-9 * back.ravel()
    assert gone.sum() > 10 and np.abs(back).max() > 0
    assert np.abs(got - expected).max() < 1e-12 * np.abs(whole).max()
    asm.destroy()


def test_the_compiled_bond_loop_matches_the_numpy_reference(tmp_path):
    """Random displacements of 1e-3 a with critical strains that break about a
    third of the bonds: the compiled loop (solver/partitions/bond_kernel.py) and
    the numpy path break the same bonds and give the same forces to 1e-12."""
    asm, dem = dem_of(nonlinear(model__lattice__break_strain=1.0), tmp_path)
    f = dem.force
    rng = np.random.default_rng(3)
    dem.U[:] = 2e-7 * rng.standard_normal(dem.U.size)
    x = f.X + dem.U.reshape(-1, 2)                             # one rank: no ghosts
    strain = np.linalg.norm(x[f.j] - x[f.i], axis=1) / f.L0 - 1
    f.limit = np.full(len(f.k), np.quantile(strain, 0.67))
    out = []
    for evaluate in (f.internal, f.reference_internal):
        f.alive[:] = True
        f.broken, f.released, f._u_last = [], 0.0, None      # (no earlier evaluation)
        evaluate(dem.u, dem.r)
        out.append((dem.R.copy(), f.alive.copy(), np.array(f.broken), f.released))
    (a, alive_a, rows_a, rel_a), (b, alive_b, rows_b, rel_b) = out
    assert 0.2 < (~alive_a).mean() < 0.5 and np.array_equal(alive_a, alive_b)
    assert np.abs(a - b).max() <= 1e-12 * np.abs(b).max()
    assert np.allclose(rows_a, rows_b, rtol=1e-12, equal_nan=True) and abs(rel_a / rel_b - 1) < 1e-12
    asm.destroy()


@pytest.mark.parametrize("law", ["linear", "hertz"])
def test_contact_laws_and_the_dashpot_on_two_particles(law):
    """Two unbonded particles of radius r at overlap d approaching at speed w:
    the spring force is k d (linear) or k d^1.5 (hertz) with energy 1/2 k d^2 or
    2/5 k d^2.5, the dashpot adds 2 zeta sqrt(k_t m*) w (k_t the tangent) and
    dissipates c w^2; both act along the line of centres, equal and opposite."""
    from solver.laws import CONTACT_LAWS, ContactSettings
    from solver.partitions.contact import Contact
    r, k, zeta, d, w = 1e-3, 2e7, 0.3, 1e-5, 0.4
    m = np.array([2e-6, 6e-6])
    unit = np.array([0.6, 0.8])
    x = np.array([[0.0, 0.0], (2 * r - d) * unit])
    settings = ContactSettings(CONTACT_LAWS[law](k), r, 0.3 * r, zeta, 0.0, 0.5)
    c = Contact(np.arange(2), settings, np.zeros(0, np.int64), np.zeros(0, np.int64), m)
    out = np.zeros((2, 2))
    c.forces(x, np.zeros(0, bool), out, 2)
    f, kt, energy = ((k * d, k, 0.5 * k * d ** 2) if law == "linear" else
                     (k * d ** 1.5, 1.5 * k * d ** 0.5, 0.4 * k * d ** 2.5))
    assert np.allclose(out[1], f * unit, rtol=1e-9) and np.allclose(out[0], -out[1], rtol=1e-12)
    assert abs(c.energy / energy - 1) < 1e-9
    v = np.array([[0.0, 0.0], -w * unit])                     # particle 1 approaches
    dash = np.zeros((2, 2))
    power = c.viscous(v, dash, 2)
    cn = 2 * zeta * np.sqrt(kt * m[0] * m[1] / m.sum())
    assert np.allclose(dash[1], cn * w * unit, rtol=1e-9) and np.allclose(dash[0], -dash[1])
    assert abs(power / (cn * w ** 2) - 1) < 1e-12


@pytest.mark.parametrize("speed, limited", [(0.5, False), (50.0, True)])
def test_friction_opposes_sliding_up_to_the_coulomb_limit(speed, limited):
    """Two pressed particles (overlap d, normal force k d) sliding past each
    other at speed w: the tangential force opposes the sliding with magnitude
    c_t w while below mu k d, and mu k d beyond it; its power is f_t w; no
    normal component; equal and opposite."""
    from solver.laws import CONTACT_LAWS, ContactSettings
    from solver.partitions.contact import Contact
    r, k, d, mu, zt = 1e-3, 2e7, 1e-5, 0.3, 0.5
    m = np.array([2e-6, 6e-6])
    unit, tang = np.array([0.6, 0.8]), np.array([-0.8, 0.6])
    x = np.array([[0.0, 0.0], (2 * r - d) * unit])
    settings = ContactSettings(CONTACT_LAWS["linear"](k), r, 0.3 * r, 0.0, mu, zt)
    c = Contact(np.arange(2), settings, np.zeros(0, np.int64), np.zeros(0, np.int64), m)
    c.forces(x, np.zeros(0, bool), np.zeros((2, 2)), 2)
    out = np.zeros((2, 2))
    power = c.viscous(np.array([[0.0, 0.0], speed * tang]), out, 2)
    ct = 2 * zt * np.sqrt(k * m[0] * m[1] / m.sum())
    ft = mu * k * d if limited else ct * speed
    assert (ct * speed > mu * k * d) == limited
    assert np.allclose(out[1], -ft * tang, rtol=1e-9) and np.allclose(out[0], -out[1])
    assert abs(power / (ft * speed) - 1) < 1e-12


@pytest.mark.parametrize("model", ["viscous", "history"])
def test_a_crack_closing_on_a_spring_dashpot_dissipates_and_the_audit_closes(tmp_path, model):
    """The closing-crack scene with a dashpot ratio of 0.5 and friction 0.3,
    viscous or on shear springs (friction_model history): compression still
    passes, the contacts dissipate energy (dashpots and sliding), and kinetic
    + strain (the springs' 1/2 k_t xi^2 included) + released + dissipated =
    work to 1e-3."""
    res = crack({"stiffness": 1.68e7, "damping_ratio": 0.5, "friction": 0.3,
                 "friction_model": model}, tmp_path)
    t, s = res.probes["C"]["t"], res.probes["C"]["stress"]
    assert s[t > 7.0e-5].min() < -0.8 * 1.0e4 / 3.2e-4
    e = res.energy
    released = res.partitions["dem"]["released_energy"]
    work = e["external_work"][-1]
    assert e["dissipated"][-1] > 0
    assert abs(e["total"][-1] + released + e["dissipated"][-1] - work) < 1e-3 * abs(work)
