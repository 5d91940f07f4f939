"""Prescribed motion (``model.prescribed``): a bar whose end is driven at a
constant velocity V carries the 1D wave of stress rho c V and particle velocity
V; the support's work closes the energy balance and equals rho c V^2 A t; the
driven DOFs stay exactly on their path with every integrator and scheme; a
static solve lifts a prescribed displacement (a bar stretched by delta: the
exact linear field); 1 rank and 2 agree; an interrupted run restarts to the
same file; bad entries are refused with one line."""
import copy

import h5py
import numpy as np
import pytest

from conftest import ROOT, refused, run_cli, write_scene
from test_checkpoints import assert_same, interrupted_then_restarted

E, RHO, T, H = 70.0e9, 2700.0, 3.2e-4, 2.4e-3      # wave_bar.geo: 0.32 m x 2.4 mm, plane stress
C = (E / RHO) ** 0.5
V, RAMP = 1.0, 3.0e-6


def pulled(**model):
    """The wave bar, its left end driven in x at a velocity ramped to V over
    RAMP, probes at 160 mm and on the driven end."""
    return {
        "name": "pulled",
        "time": {"end": 4.0e-5, "dt": 2.0e-8},
        "model": {"kind": "continuum", "mesh": str(ROOT / "meshes" / "wave_bar.geo"),
                  "material": {"E": E, "nu": 0.33, "rho": RHO, "kind": "plane_stress",
                               "thickness": T},
                  "body": "solid",
                  "prescribed": [{"group": "left", "dofs": ["ux"], "quantity": "velocity",
                                  "kind": "tabulated", "table": [[0.0, 0.0], [RAMP, V], [1.0, V]]}],
                  **model},
        "partitions": [{"name": "fem", "method": "fem", "group": "solid",
                        "integrator": "explicit", "ratio": 1}],
        "probes": [{"name": "B", "at": [0.16, 0.0012]}, {"name": "end", "at": [0.0, 0.0012]}],
    }


def run(raw, tmp_path, name, n=None, sets=()):
    raw = copy.deepcopy(raw)
    raw["name"] = name
    raw["output"] = {"file": str(tmp_path / f"{name}.h5"), "progress": 0}
    args = [write_scene(tmp_path / f"{name}.yaml", raw)]
    for s in sets:
        args += ["--set", s]
    proc = run_cli(args, n=n, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return tmp_path / f"{name}.h5", proc.stdout


def test_a_bar_driven_at_constant_velocity_carries_rho_c_v(tmp_path):
    path, out = run(pulled(), tmp_path, "pulled")
    assert "prescribed[0]: 5 DOFs move with a given velocity (tabulated)" in out
    with h5py.File(path) as f:
        t = f["probes/B/t"][()]
        late = t >= 0.16 / C + 2 * RAMP                   # behind the front at B
        v, s = f["probes/B/velocity"][()][late], f["probes/B/stress"][()][late]
        assert np.abs(v / V - 1).max() < 0.03             # (lateral inertia rings: 2 %)
        assert abs(np.mean(s) / (-RHO * C * V) - 1) < 0.005  # compression rho c V
        # the driven end is on its path, to round-off
        end = f["probes/end"]
        te = end["t"][()]
        u = np.where(te < RAMP, V * te ** 2 / (2 * RAMP), V * (te - RAMP / 2))
        assert np.abs(end["displacement"][()] - u).max() < 1e-12 * u[-1]
        assert np.abs(end["velocity"][()] - V * np.minimum(te / RAMP, 1)).max() < 1e-12
        e = f["energy"]
        total, work, te = e["total"][()], e["external_work"][()], e["t"][()]
        power = RHO * C * V ** 2 * H * T                  # the support's power, 10.56 W
        assert abs(work[-1] / (power * (te[-1] - 2 * RAMP / 3)) - 1) < 0.005
        assert np.abs(total - total[0] - work).max() < 1e-4 * work[-1]


@pytest.mark.parametrize("sets, balance", [
    (["partitions.fem.integrator=implicit"], 1e-10),
    (["partitions.fem.integrator=implicit", "time.dt=2e-7"], 1e-10),   # 1.8 x critical
    (["partitions.fem.beta=0.0"], 2e-3)])
def test_every_integrator_ends_on_a_prescribed_sine(tmp_path, sets, balance):
    """Average acceleration balances the support's trapezoidal work exactly,
    at any step (the reaction taken at the corrected state)."""
    raw = pulled()
    raw["time"]["end"] = 1.0e-5
    raw["model"]["prescribed"] = [{"group": "left", "dofs": ["ux", "uy"],
                                   "quantity": "displacement", "kind": "sine",
                                   "amplitude": 1e-6, "omega": 3.0e5}]
    path, _ = run(raw, tmp_path, "sine", sets=sets)
    with h5py.File(path) as f:
        end = f["probes/end"]
        t = end["t"][()]
        assert np.abs(end["displacement"][()] - 1e-6 * np.sin(3e5 * t)).max() < 1e-18
        assert np.abs(end["velocity"][()] - 0.3 * np.cos(3e5 * t)).max() < 1e-12
        e = f["energy"]
        drift = np.abs(e["total"][()] - e["total"][0] - e["external_work"][()]).max()
        assert drift < balance * np.abs(e["external_work"][()]).max()


def test_two_ranks_and_a_coupled_scheme_drive_the_same_bar(tmp_path):
    one, _ = run(pulled(), tmp_path, "one")
    two, _ = run(pulled(), tmp_path, "two", n=2)
    with h5py.File(one) as a, h5py.File(two) as b:
        for key in ("velocity", "stress", "displacement"):
            x, y = a[f"probes/B/{key}"][()], b[f"probes/B/{key}"][()]
            assert np.abs(x - y).max() <= 1e-10 * np.abs(x).max(), key
        assert np.abs(a["energy/external_work"][()] - b["energy/external_work"][()]).max() \
            <= 1e-10 * a["energy/external_work"][-1]
    # two partitions, the driven end in the implicit one (staggered, ratio 3)
    raw = pulled(mesh=str(ROOT / "meshes" / "wave_bar_coupled.geo"))
    raw["time"] = {"end": 3.996e-5, "dt": 1.5e-8}
    raw["partitions"] = [
        {"name": "fine", "method": "fem", "group": "dem", "integrator": "explicit", "ratio": 1},
        {"name": "coarse", "method": "fem", "group": "fem", "integrator": "implicit", "ratio": 3}]
    raw["coupling"] = {"scheme": "staggered"}
    path, _ = run(raw, tmp_path, "staggered")
    with h5py.File(path) as f:
        end = f["probes/end"]
        te = end["t"][()]
        u = np.where(te < RAMP, V * te ** 2 / (2 * RAMP), V * (te - RAMP / 2))
        assert np.abs(end["displacement"][()] - u).max() < 1e-12 * u[-1]
        s = f["probes/B/stress"][()][f["probes/B/t"][()] >= 0.16 / C + 2 * RAMP]
        assert abs(np.mean(s) / (-RHO * C * V) - 1) < 0.05
        e = f["energy"]
        assert abs(e["total"][-1] - e["total"][0] - e["external_work"][-1]) < \
            1e-3 * e["external_work"][-1]


def test_a_shell_plate_shaken_at_its_edges_follows_them(tmp_path):
    """Shell DOFs, translations and rotations: the simply supported plate's edges
    shaken in z (a displacement sine) and turned about x (a half-sine velocity)."""
    from conftest import raw_scene
    raw = raw_scene("plate_shell")
    raw["time"]["end"] = 3.0e-3
    raw["loads"] = []
    raw["model"]["constraints"] = [{"group": "edges", "dofs": ["ux", "uy"]}]
    raw["model"]["prescribed"] = [
        {"group": "edges", "dofs": ["uz"], "quantity": "displacement", "kind": "sine",
         "amplitude": 1e-3, "omega": 2000.0},
        {"group": "edges", "dofs": ["rx"], "quantity": "velocity", "kind": "half_sine",
         "amplitude": 0.1, "duration": 1e-3}]
    raw["probes"] = [{"name": "z", "at": [0.5, 0.0, 0.0], "component": 2},
                     {"name": "rx", "at": [0.5, 0.0, 0.0], "component": 3},
                     {"name": "centre", "at": [0.5, 0.5, 0.0], "component": 2}]
    path, out = run(raw, tmp_path, "shaken")
    assert "prescribed[1]: 64 DOFs move with a given velocity (half_sine)" in out
    with h5py.File(path) as f:
        t = f["probes/z/t"][()]
        assert np.abs(f["probes/z/displacement"][()] - 1e-3 * np.sin(2000 * t)).max() < 1e-17
        k = np.pi / 1e-3
        turned = 0.1 / k * (1 - np.cos(k * np.minimum(t, 1e-3)))
        assert np.abs(f["probes/rx/displacement"][()] - turned).max() < 1e-17
        assert abs(f["probes/centre/displacement"][-1]) > 1e-3     # the plate moves with them
        e = f["energy"]
        work = np.abs(e["external_work"][()]).max()
        assert np.abs(e["total"][()] - e["total"][0] - e["external_work"][()]).max() < 1e-4 * work


def test_an_interrupted_driven_run_restarts_to_the_same_file(tmp_path):
    raw = pulled()
    raw["probes"] = raw["probes"][:1]
    whole, restarted = interrupted_then_restarted(raw, tmp_path, 1.0e-5)
    assert_same(whole, restarted)


def stretched(delta=1e-5, n=None, tmp_path=None, name="stretch"):
    """A 3D block (nu = 0) fixed at x = 0 and stretched by delta at x = L, solved
    statically: u = delta x / L exactly, sigma_xx = E delta / L."""
    raw = {
        "name": name,
        "analysis": "static",
        "time": {"end": 1.0, "dt": 1.0},
        "model": {"kind": "continuum", "mesh": str(ROOT / "meshes" / "block3d.geo"),
                  "mesh_parameters": {"L": 0.06, "W": 0.02, "H": 0.02, "nx": 6, "ny": 2,
                                      "nz": 2},
                  "material": {"E": E, "nu": 0.0, "rho": RHO, "kind": "solid"},
                  "body": "solid", "fixed": ["left"],
                  "prescribed": [{"group": "right", "dofs": ["ux"], "quantity": "displacement",
                                  "kind": "tabulated", "table": [[0.0, 0.0], [1.0, delta]]}]},
        "probes": [{"name": "mid", "at": [0.03, 0.01, 0.01]},
                   {"name": "mid_y", "at": [0.03, 0.01, 0.01], "component": 1}],
    }
    return run(raw, tmp_path, name, n=n)[0]


def test_a_static_solve_lifts_a_prescribed_displacement(tmp_path):
    delta, L, A = 1e-5, 0.06, 0.02 * 0.02
    paths = [stretched(delta, None, tmp_path, "one"), stretched(delta, 2, tmp_path, "two")]
    for path in paths:
        with h5py.File(path) as f:
            assert f["probes/mid/displacement"][()].tolist() == pytest.approx(
                [delta / 2], rel=1e-9)
            assert abs(f["probes/mid_y/displacement"][0]) < 1e-9 * delta
            assert f["probes/mid/stress"][0] == pytest.approx(E * delta / L, rel=1e-9)
            strain = 0.5 * E * A * delta ** 2 / L
            assert f["energy/strain"][-1] == pytest.approx(strain, rel=1e-9)
            assert f["energy/external_work"][-1] == pytest.approx(strain, rel=1e-9)


BAD = [
    (["model.prescribed.0.group=nope"], "model.prescribed[0].group: mesh has no physical group 'nope'"),
    (["model.prescribed.0.dofs=[uz]"], "model.prescribed[0].dofs: uz does not exist"),
    (["model.fixed=[left]"], "model.prescribed[0].group: node"),
    (["model.prescribed.0.kind=rectangular", "model.prescribed.0.quantity=displacement",
      "model.prescribed.0.table=null", "model.prescribed.0.duration=1e-6"],
     "model.prescribed[0].kind: a rectangular displacement jumps"),
    (["model.prescribed.0.table=null"], "model.prescribed[0].table: required for a tabulated motion"),
    (["model.prescribed.0.dofs=[ux, ux]"], "model.prescribed[0].dofs: ['ux', 'ux'] names a DOF twice"),
    (["initial.motion=[{group: left, velocity: [2.0, 0]}]"], "initial.motion[0].velocity: node"),
    (["coupling.scheme=conserving"], "model.prescribed: the conserving scheme builds"),
    (["partitions=auto", "time.dt=auto"], "model.prescribed: partition 'auto' steps by element levels"),
]


@pytest.mark.parametrize("sets, start", BAD)
def test_bad_prescribed_motion_is_refused_in_one_line(tmp_path, sets, start):
    scene = write_scene(tmp_path / "pulled.yaml", pulled())
    line = refused(scene, sets, tmp_path)
    assert line.startswith(f"error: {start}") or line.startswith(f"error: {scene}: {start}"), line


def test_two_entries_on_one_dof_are_refused(tmp_path):
    raw = pulled()
    raw["model"]["prescribed"] = raw["model"]["prescribed"] * 2
    scene = write_scene(tmp_path / "twice.yaml", raw)
    line = refused(scene, [], tmp_path)
    assert "model.prescribed[1].group: node" in line and "held by model.prescribed[0]" in line


def test_a_rotation_driven_on_solid_nodes_is_refused(tmp_path):
    """Shells on a solid: a solid-only node has no rotation to drive (its
    rotations are held), so rx on the block's root face is refused."""
    from test_shell import block_strip
    raw = block_strip()
    raw["model"]["fixed"] = []
    raw["model"]["prescribed"] = [{"group": "root", "dofs": ["ux", "rx"],
                                   "quantity": "velocity", "kind": "sine", "amplitude": 1.0,
                                   "omega": 1e3}]
    line = refused(write_scene(tmp_path / "turned.yaml", raw), [], tmp_path)
    assert "model.prescribed[0].dofs: ['rx']: node" in line and "only shell nodes rotate" in line


def test_the_guard_knows_the_step_of_a_driven_bar(tmp_path):
    """The driven DOFs are held in the stability check as fixed ones are: the
    driven bar's critical step is refused at 1.01 x and run at 0.99 x."""
    from conftest import run_scene
    raw = pulled()
    raw["time"] = {"end": 2e-7, "dt": 2e-8}
    crit = run_scene(raw, tmp_path).partitions["fem"]["critical_step"]
    assert crit == pytest.approx(1.111e-7, rel=1e-3)
    for factor, code in ((1.01, 2), (0.99, 0)):
        raw["time"] = {"end": 10 * factor * crit, "dt": factor * crit}
        raw["output"] = {"file": str(tmp_path / f"g{factor}.h5"), "progress": 0}
        proc = run_cli([write_scene(tmp_path / f"g{factor}.yaml", raw)])
        assert proc.returncode == code, (factor, proc.stderr)
        if code:
            assert "is unstable, critical step 1.11" in proc.stderr
