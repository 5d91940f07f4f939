"""Continua that start moving (initial.motion, by group and by position) and
gravity, against exact solutions: the struck bar's rho c v / 2, a prestrained
bar's strain energy, free fall, a hanging bar's static stretch; 1 vs 2 ranks;
bad input."""
import h5py
import numpy as np
import pytest

from conftest import raw_scene, run_cli, run_scene, write_scene

E, RHO, NU, THICK = 70e9, 2700.0, 0.33, 3.2e-4     # configs/wave_bar_fem.yaml's aluminium
L, H, DX = 0.32, 0.0024, 0.001                    # meshes/wave_bar.geo: 320 x 4 quads
C = np.sqrt(E / RHO)


def free_bar(end, **over):
    """configs/wave_bar_fem.yaml with no load, no support and no reference."""
    raw = raw_scene("wave_bar_fem")
    raw["name"] = "moving_bar"
    raw["time"] = {"end": end, "dt": 2.0e-8}
    del raw["model"]["fixed"], raw["reference"]
    raw["loads"] = []
    raw["probes"] = [{"name": "ahead", "at": [0.2, 0.0012]}, {"name": "behind", "at": [0.12, 0.0012]}]
    raw.update(over)
    return raw


def test_a_struck_bar_carries_half_the_striker_velocity(tmp_path):
    """The left half moving at v into the right half at rest: waves of particle
    velocity v/2 (stress rho c v/2) run both ways from x = 0.16 (1D solution)."""
    v = 2.0
    res = run_scene(free_bar(2.0e-5, initial={"motion": [
        {"velocity": [f"{v} * (x < 0.1595)", 0]}]}), tmp_path)   # (mid-cell: no node on the edge)
    arrive = 0.04 / C                                   # both probes are 40 mm from x = 0.16
    for name, before in (("ahead", 0.0), ("behind", v)):
        pr = res.probes[name]
        t, vx = pr["t"], pr["velocity"]
        # before the front (the strip's dispersion sends a precursor of 5e-5 v ahead)
        assert np.abs(vx[t < 0.8 * arrive] - before).max() < 1e-3 * v, name
        plateau = vx[t > 1.5 * arrive].mean()
        assert abs(plateau / (v / 2) - 1) < 0.02, (name, plateau)
    # the striker's kinetic energy, exactly: the lumped masses of the nodes at x < 0.16
    en = res.energy
    striker = RHO * THICK * H * (0.16 - DX / 2)
    assert abs(en["kinetic"][0] / (0.5 * striker * v ** 2) - 1) < 1e-12
    total = en["kinetic"] + en["strain"]
    assert np.abs(total / total[0] - 1).max() < 1e-3           # conserved (no load, no damping)
    # the contact stress is rho c v / 2: the strain energy flowing in matches it
    # (sigma = rho c v/2 over 2 c t of bar: strain energy sigma^2/(2E) each side)
    t = en["t"]
    late = t > 0.5 * arrive
    expected = (RHO * C * v / 2) ** 2 / (2 * E) * THICK * H * 2 * C * t[late]
    assert np.abs(en["strain"][late] / expected - 1).max() < 0.05


def test_an_initial_displacement_holds_its_strain_energy(tmp_path):
    """u = eps x, v = 0 (plane stress, uniaxial strain): strain energy
    E eps^2 / (2 (1 - nu^2)) per volume, exactly (bilinear quads hold a linear field)."""
    eps = 1e-4
    res = run_scene(free_bar(2.0e-7, initial={"motion": [
        {"displacement": [f"{eps} * x", 0]}]}), tmp_path)
    exact = E * eps ** 2 / (2 * (1 - NU ** 2)) * L * H * THICK
    assert abs(res.energy["strain"][0] / exact - 1) < 1e-12
    assert res.energy["kinetic"][0] == 0.0
    assert abs(res.probes["ahead"]["displacement"][0] / (eps * 0.2) - 1) < 1e-12


def test_a_mode_shape_that_vanishes_at_the_support_is_taken(tmp_path):
    """sin(pi x / L) is 6e-17, not 0, at the fixed end x = L: round-off on a
    fixed axis is zeroed, not refused (motion there is)."""
    raw = free_bar(2.0e-7, initial={"motion": [{"velocity": [0, "0.1 * sin(pi * x / 0.32)"]}]})
    raw["model"]["fixed"] = ["right"]
    res = run_scene(raw, tmp_path)
    exact = 0.5 * RHO * THICK * H * L * 0.1 ** 2 * 0.5     # 1/2 m v^2, the mean of sin^2 1/2
    assert abs(res.energy["kinetic"][0] / exact - 1) < 1e-9


def test_motion_by_group_and_in_order(tmp_path):
    """A later entry overrides an earlier one on its group: the whole bar at w,
    then its left edge (5 nodes, mass rho t H dx / 2) at v."""
    w, v = 1.0, 3.0
    res = run_scene(free_bar(2.0e-7, initial={"motion": [
        {"velocity": [0, w]}, {"group": "left", "velocity": [v, 0]}]}), tmp_path)
    edge = RHO * THICK * H * DX / 2
    exact = 0.5 * (RHO * THICK * H * L - edge) * w ** 2 + 0.5 * edge * v ** 2
    assert abs(res.energy["kinetic"][0] / exact - 1) < 1e-12


def test_free_fall_is_exact(tmp_path):
    """Gravity on an unsupported bar: every node falls u = -g t^2 / 2 (explicit
    Newmark integrates a constant acceleration exactly); no strain; kinetic
    energy = the work of gravity."""
    g = 9.81
    res = run_scene(free_bar(4.0e-6, gravity=[0, -g]), tmp_path)
    t = res.probes["ahead"]["t"]
    uy = res.probes["ahead"]["displacement"]
    raw = free_bar(4.0e-6, gravity=[0, -g])
    raw["probes"] = [{"name": "ahead", "at": [0.2, 0.0012], "component": 1}]
    uy = run_scene(raw, tmp_path).probes["ahead"]["displacement"]
    assert np.abs(uy - (-0.5 * g * t ** 2)).max() < 1e-12 * 0.5 * g * t[-1] ** 2
    en = res.energy
    assert abs(en["kinetic"][-1] / en["external_work"][-1] - 1) < 1e-9
    assert abs(en["strain"]).max() < 1e-12 * en["kinetic"][-1]


def test_a_hanging_bar_stretches_rho_g_L2_over_2E(tmp_path):
    """Fixed at x = L, pulled towards -x by gravity: the free end's static
    displacement is -rho g L^2 / (2 E) (1D); suddenly applied, the undamped bar
    oscillates about it, and its mean over the fundamental period 4 L / c is
    the static value (the rod's modes are odd multiples of the fundamental)."""
    g = 1000.0
    period = 4 * L / C
    raw = free_bar(round(period / 2e-8) * 2e-8, gravity=[-g, 0])
    raw["model"]["fixed"] = ["right"]
    raw["probes"] = [{"name": "tip", "at": [0.0, 0.0012]}]
    pr = run_scene(raw, tmp_path).probes["tip"]
    u = pr["displacement"]
    static = -RHO * g * L ** 2 / (2 * E)
    mean = 0.5 * (u[1:] + u[:-1]).mean()                 # trapezoidal mean over the period
    assert abs(mean / static - 1) < 0.02, (mean, static)
    assert abs(u.min() / (2 * static) - 1) < 0.05          # a sudden load overshoots to twice


def test_moving_start_is_the_same_on_one_and_two_ranks(tmp_path):
    """Striker, prestrain and gravity together, one partition split over 2 ranks."""
    raw = free_bar(4.0e-6, gravity=[0, -9.81], initial={"motion": [
        {"velocity": ["5 * (x < 0.1595)", "0.1 * sin(pi * x / 0.32)"]},
        {"group": "right", "displacement": [1e-5, 0]}]})
    files = []
    for n in (None, 2):
        raw["output"] = {"file": str(tmp_path / f"r{n}.h5")}
        proc = run_cli([write_scene(tmp_path / f"s{n}.yaml", raw)], n=n, timeout=300)
        assert proc.returncode == 0, proc.stderr
        files.append(h5py.File(tmp_path / f"r{n}.h5"))
    a, b = files
    assert b.attrs["ranks"] == 2
    for name in ("ahead", "behind"):
        for q in ("displacement", "velocity"):
            x, y = a[f"probes/{name}/{q}"][()], b[f"probes/{name}/{q}"][()]
            assert np.abs(x - y).max() <= 1e-12 * np.abs(x).max(), (name, q)
    for q in ("kinetic", "strain", "external_work"):
        x, y = a[f"energy/{q}"][()], b[f"energy/{q}"][()]
        assert np.abs(x - y).max() <= 1e-12 * np.abs(x).max(), q


@pytest.mark.parametrize("edit, message", [
    (lambda r: r.update(initial={"motion": [{"group": "right", "velocity": [1, 0]}]},
                        model={**r["model"], "fixed": ["right"]}),
     "initial.motion[0].velocity: node 1 at [0.32, 0.0] is held in x (model.fixed, "
     "model.constraints or model.prescribed) but would start with velocity 1 there"),
    (lambda r: r.update(initial={"motion": [{"group": "nope", "velocity": [1, 0]}]}),
     "initial.motion[0].group: mesh has no physical group 'nope'"),
    (lambda r: r.update(initial={"motion": [{"velocity": [1, 0, 0]}]}),
     "initial.motion[0].velocity: [1.0, 0.0, 0.0] has 3 entries; this 2D model needs 2"),
    (lambda r: r.update(initial={"motion": [{"velocity": ["__import__('os')", 0]}]}),
     "initial.motion[0].velocity[0]: \"__import__('os')\": the function '__import__' is not "
     "allowed"),
    (lambda r: r.update(initial={"motion": [{"velocity": ["2 * t", 0]}]}),
     "initial.motion[0].velocity[0]: '2 * t': the name 't' is not allowed"),
    (lambda r: r.update(initial={"motion": [{"velocity": ["log(x)", 0]}]}),
     "initial.motion[0].velocity[0]: 'log(x)' is -inf at [0.0, "),
    (lambda r: r.update(initial={"motion": [{"group": "left"}]}),
     "initial.motion[0]: give velocity or displacement (or both)"),
    (lambda r: r.update(initial={"velocity": {3: 1.0}}),
     "initial.velocity: node -> value initial states are for network models"),
    (lambda r: r.update(gravity=[0, -9.81, 0]),
     "gravity: [0.0, -9.81, 0.0] has 3 entries; this 2D model needs 2"),
])
def test_bad_initial_motion_and_gravity(edit, message, tmp_path):
    raw = free_bar(2e-7)
    edit(raw)
    raw["output"] = {"file": str(tmp_path / "bad.h5")}
    proc = run_cli([write_scene(tmp_path / "bad.yaml", raw)])
    assert proc.returncode == 2, proc.stderr
    assert message in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr
    assert not (tmp_path / "bad.h5").exists()


def test_gravity_and_motion_are_for_continua(tmp_path):
    raw = raw_scene("six_dof")
    raw["output"] = {"file": str(tmp_path / "net.h5")}
    for key, value, message in (("gravity", [0, -9.81], "gravity: is for continuum models"),
                                ("initial", {"motion": [{"velocity": [1]}]},
                                 "initial.motion: is for continuum models")):
        bad = {**raw, key: value}
        proc = run_cli([write_scene(tmp_path / "net.yaml", bad)])
        assert proc.returncode == 2 and message in proc.stderr, proc.stderr


def test_a_coupled_lattice_bar_translates_and_falls_as_one_body(tmp_path):
    """configs/bar3d.yaml (FEM and a bonded DEM block, overlapping) unsupported,
    moving at w and falling under g: every node of both partitions keeps
    v = w + g t exactly (a rigid motion strains no cell and no bond)."""
    raw = raw_scene("bar3d")
    raw["time"] = {"end": 1.0e-6, "dt": 2.0e-8}
    del raw["model"]["fixed"]
    raw["loads"] = []
    w, g = (3.0, 0.0, -1.0), (0.0, -9.81, 0.0)
    raw["initial"] = {"motion": [{"velocity": list(w)}]}
    raw["gravity"] = list(g)
    raw["probes"] = [{"name": f"{p}{c}", "at": at, "component": c}
                     for p, at in (("D", [0.010, 0.0012, 0.0004]), ("F", [0.016, 0.0012, 0.0004]))
                     for c in range(3)]
    res = run_scene(raw, tmp_path)
    assert res.probes["D0"]["attrs"]["partition"] == "dem"
    assert res.probes["F0"]["attrs"]["partition"] == "fem"
    for name, pr in res.probes.items():
        c = int(name[1])
        t = pr["t"]
        assert np.abs(pr["velocity"] - (w[c] + g[c] * t)).max() < 1e-12 * 10, name
        assert np.abs(pr["displacement"] - (w[c] * t + 0.5 * g[c] * t ** 2)).max() < 1e-12, name
    en = res.energy
    assert np.abs(en["strain"]).max() < 1e-12 * en["kinetic"][0]


def test_a_shell_plate_falls_with_its_rotations_at_rest(tmp_path):
    """configs/plate_shell.yaml unsupported, thrown up at 0.5 m/s under gravity:
    its 6-DOF nodes take v and g on their translations, the rotations stay at
    rest (no strain)."""
    raw = raw_scene("plate_shell")
    raw["time"] = {"end": 3.0e-5, "dt": 1.5e-6}
    del raw["model"]["constraints"]
    raw["loads"] = []
    raw["gravity"] = [0.0, 0.0, -9.81]
    raw["initial"] = {"motion": [{"velocity": [0.0, 0.0, "0.5"]}]}
    res = run_scene(raw, tmp_path)
    pr = res.probes["centre"]
    t = pr["t"]
    assert np.abs(pr["velocity"] - (0.5 - 9.81 * t)).max() < 1e-12
    en = res.energy
    assert np.abs(en["strain"]).max() < 1e-12 * en["kinetic"][0]


def test_a_falling_run_goes_on_from_its_checkpoint(tmp_path):
    """Gravity's load groups and the initial state survive a restart: a run to
    2 us continued to 4 us equals one run to 4 us, bitwise."""
    raw = free_bar(4.0e-6, gravity=[0, -9.81], initial={"motion": [
        {"velocity": ["3 * (x < 0.1595)", "0.5 * (x < 0.3)"]}]})   # the fixed end at rest
    raw["model"]["fixed"] = ["right"]
    raw["output"] = {"file": str(tmp_path / "whole.h5"), "energy_every": 10}
    assert run_cli([write_scene(tmp_path / "whole.yaml", raw)]).returncode == 0
    raw["output"] = {"file": str(tmp_path / "cut.h5"), "energy_every": 10,
                     "checkpoint": {"every": 50}}
    cut = write_scene(tmp_path / "cut.yaml", raw)
    assert run_cli([cut, "--set", "time.end=2e-6"]).returncode == 0
    proc = run_cli([cut, "--restart", tmp_path / "cut.h5"])
    assert proc.returncode == 0, proc.stderr
    with h5py.File(tmp_path / "whole.h5") as a, h5py.File(tmp_path / "cut.h5") as b:
        for key in ("probes/ahead/displacement", "probes/behind/velocity", "energy/external_work",
                    "energy/kinetic"):
            assert np.array_equal(a[key][()], b[key][()]), key
