"""Zhang et al.'s (2009) transition zone: particles inside coarse band cells (issue 9).

The model (masses, carried bonds, stresses) against exact values; the
wave_bar scene against the 1D solution; the step guard naming both sides;
bad input; 1 vs 2 ranks (tests/test_parallel.py runs the MPI side)."""
from __future__ import annotations

import numpy as np
import pytest

from conftest import built, raw_scene, refused, run_cli, run_scene, write_scene
from solver.errors import SceneError

E, NU, RHO, T = 70e9, 0.33, 2700.0, 3.2e-4
L, H = 0.32, 0.0024


def scene_with(**mesh):
    raw = raw_scene("wave_bar_transition")
    raw["model"]["mesh_parameters"] = {**raw["model"]["mesh_parameters"], **mesh}
    return raw


def model_of(raw, tmp_path):
    from solver import scene as scene_mod
    from solver.model import binding, continuum
    raw = dict(raw, output={"file": str(tmp_path / "m.h5")})
    bound = binding.bind(scene_mod.from_dict(raw))
    return bound, continuum.build(bound)


def full_stiffness(mdl):
    """The whole model's K (cells, core bonds, carried bonds) as a sparse (CSR)
    matrix: with a transition band, the blocks of a partition holding every
    node (dense, the 11,604 DOFs of the three-layer band took 1 GB and 5 s)."""
    from scipy.sparse import coo_matrix
    from solver.partitions.assembly import triplets
    held = np.arange(mdl.n_nodes)
    rows, cols, vals = triplets(mdl.stiffness_blocks(held), mdl.dofmap)
    return coo_matrix((vals, (rows, cols)), shape=(mdl.n_dofs, mdl.n_dofs)).tocsr()


@pytest.mark.parametrize("layers,tri", [(3, 0), (5, 0), (4, 1)])
def test_band_mass_matching_and_carried_bonds(layers, tri, tmp_path):
    """Eq. 5: FE cells + band particle masses + core particles weigh rho t L H to
    round-off; the carried bonds (eq. 3-4) exert no force in a rigid motion and
    the model's stiffness is the lattice's + the FE cells' (symmetric)."""
    bound, mdl = model_of(scene_with(layers=layers, tri=tri), tmp_path)
    zone = mdl.zone
    assert abs(mdl.mass.sum() - RHO * T * L * H) < 1e-12 * RHO * T * L * H
    # the band nodes carry exactly the band particles' mass and its first moment
    assert abs(zone.node_mass.sum() - zone.band_mass.sum()) < 1e-13 * zone.band_mass.sum()
    moment = (zone.node_mass[:, None] * mdl.points[:zone.n_mesh]).sum(axis=0)
    assert np.allclose(moment, (zone.band_mass[:, None] * zone.band_points).sum(axis=0),
                       rtol=1e-12, atol=0)
    # layers x rows of particles in each band, (21 - 2 layers) x 13 in the core
    assert len(zone.band_points) == 2 * layers * 13 and zone.n_core == (21 - 2 * layers) * 13
    K = full_stiffness(mdl)
    scale = np.abs(K).max()
    assert np.abs(K - K.T).max() < 1e-9 * scale
    x, y = mdl.points[:, 0], mdl.points[:, 1]
    for u in (np.stack([np.ones_like(x), 0 * x], 1), np.stack([0 * x, np.ones_like(x)], 1),
              np.stack([-y, x], 1)):                       # translations, linearised rotation
        assert np.abs(K @ u.ravel()).max() < 1e-9 * scale


def test_uniform_strain_stress_in_cells_and_particles(tmp_path):
    """Under u = (eps x, 0): the bond (virial) stress of a core particle is the
    lattice's E/(1 - 1/9) eps; an FE node's cell stress is E/(1 - nu^2) eps."""
    from solver.driver.stress import bond_row, fe_row
    bound, mdl = model_of(scene_with(layers=3), tmp_path)
    eps = 1e-4
    u = np.zeros((mdl.n_nodes, 2))
    u[:, 0] = eps * mdl.points[:, 0]
    B = next(p for p in bound.probes if p.name == "B").node
    A = next(p for p in bound.probes if p.name == "A").node
    assert B >= mdl.zone.n_mesh and A < mdl.zone.n_mesh
    nodes, coef = bond_row(mdl, B, 0, RHO)
    assert abs((coef * u[nodes]).sum() - 9 / 8 * E * eps) < 1e-9 * E * eps
    nodes, coef = fe_row(mdl, A, 0)
    assert abs((coef * u[nodes]).sum() - E / (1 - NU ** 2) * eps) < 1e-9 * E * eps
    # a core particle next to the band: its carried bonds count like lattice bonds
    zone = mdl.zone
    edge = zone.core_ids[np.argmin(zone.points[:, 0] + np.abs(zone.points[:, 1] - H / 2))]
    nodes, coef = bond_row(mdl, edge, 0, RHO)
    assert abs((coef * u[nodes]).sum() - 9 / 8 * E * eps) < 1e-9 * E * eps


def test_wave_bar_transition_matches_the_1d_wave(tmp_path):
    """configs/wave_bar_transition.yaml (5 layers, FE step 4 x the DE step):
    stress arrival within 1 % of the travel time and peak within 5 % at A (FE),
    B (DEM) and C (FE); displacements within 3 % of the 1D solution; the energy
    passing A after the pulse (reflected by both interfaces) below 1 %."""
    res = run_scene(raw_scene("wave_bar_transition"), tmp_path)
    assert res.attrs["status"] == "completed"
    assert res.partitions["fem"]["steps"] * 4 == res.partitions["dem"]["steps"] == 5356
    for name in "ABC":
        at = res.probes[name]["attrs"]
        assert abs(at["stress_arrival_error"]) < 0.01, (name, at)
        assert abs(at["stress_peak_error"]) < 0.05, (name, at)
        assert at["max_rel_error"] < 0.03, (name, at)
    assert res.probes["B"]["attrs"]["partition"] == "dem"
    t, v = res.probes["A"]["t"], res.probes["A"]["velocity"]
    inc, after = (t >= 10e-6) & (t <= 32e-6), (t > 32e-6) & (t <= 75e-6)
    assert np.trapezoid(v[after] ** 2, t[after]) < 0.01 * np.trapezoid(v[inc] ** 2, t[inc])


def test_ratio_beyond_the_coupled_critical_step_is_refused(tmp_path):
    out = tmp_path / "x.h5"
    proc = run_cli(["configs/wave_bar_transition.yaml", "--set", "partitions.fem.ratio=5",
                    "--set", "time.end=7.497e-5", "--set", f"output.file={out}"])   # 1071 steps
    assert proc.returncode == 2, proc.stderr
    line, = proc.stderr.strip().splitlines()
    assert "partition 'fem': step 7e-08 s (ratio 5" in line
    assert "fem critical step" in line and "dem critical step" in line
    assert "largest stable ratio 4" in line and "Traceback" not in proc.stderr
    assert not out.exists()


BAD = [
    ({"model.lattice.transition": "left"}, "model.lattice.transition: group 'left' must hold 2D cells"),
    ({"model.lattice.transition": "fem"}, "does not touch region 'dem': the band must be one layer"),
    ({"model.lattice.region": "band", "model.lattice.transition": "dem",
      "partitions.dem.group": "band"}, "does not separate region 'band' from the FE cells"),
    ({"model.lattice.spacing": 2e-3}, "holds no particle of spacing 0.002 m"),
    ({"coupling.scheme": "overlap"}, "coupling.scheme: overlap: a transition band"),
    ({"coupling.external": "layers"}, "coupling.external: layers: a transition band"),
    ({"partitions.dem.group": "band"}, "partitions[1].group: 'band': with a transition band"),
    ({"partitions.fem.integrator": "implicit"}, "fem partition 'fem' must be explicit"),
]


@pytest.mark.parametrize("sets,message", BAD)
def test_bad_transition_input(sets, message, tmp_path):
    raw = raw_scene("wave_bar_transition")
    line = refused(write_scene(tmp_path / "s.yaml", raw), [f"{k}={v}" for k, v in sets.items()],
                   tmp_path)
    assert message in line, line


def test_transition_needs_its_band(tmp_path):
    """scheme transition without a band, and the key on a network model."""
    proc = run_cli(["configs/wave_bar.yaml", "--set", "coupling.scheme=transition"])
    assert proc.returncode == 2
    assert "coupling.scheme: transition: needs a continuum model with model.lattice.transition" \
        in proc.stderr
    proc = run_cli(["configs/six_dof.yaml", "--set",
                    "model.lattice={region: dem, spacing: 1.0, transition: band}"])
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1
    assert "model.lattice" in proc.stderr and "Traceback" not in proc.stderr


def short_bar(ratio, dt, beta_r, newmark_beta=0.0):
    """A 9.6 mm bar with a 4.8 mm DEM region (the stability study's model)."""
    raw = raw_scene("wave_bar_transition")
    raw["model"]["mesh_parameters"] = {"layers": 5, "L": 0.0096, "x1": 0.0024, "x2": 0.0072}
    raw["partitions"][0].update(ratio=ratio, beta=newmark_beta)
    end = max(round(1e-6 / (ratio * dt)), 1) * ratio * dt      # a whole number of system steps
    raw.update(time={"end": end, "dt": dt}, guard={"stable_step": False}, reference="none",
               probes=[], loads=[], damping={"beta": beta_r})
    return raw


def test_ratio_one_is_the_monolithic_central_difference(tmp_path):
    """At step ratio 1 the transition scheme (FE central difference, DEM Verlet,
    the band's bonds carried to its nodes) is one central-difference step of the
    whole model: u, v, a agree to round-off from a random state."""
    dt = 3e-8
    asm = built(short_bar(1, dt, 0.0), tmp_path)
    mdl, parts, scheme = asm.model, asm.parts, asm.scheme
    K = full_stiffness(mdl)
    m = np.repeat(mdl.mass, 2)
    free = (m > 0) & ~mdl.fixed
    rng = np.random.default_rng(0)
    u, vel = (np.where(free, rng.standard_normal(mdl.n_dofs), 0.0) for _ in range(2))
    minv = np.where(free, 1 / np.where(m > 0, m, 1), 0.0)
    acc = -minv * (K @ u)
    for p in parts:
        p.U[:], p.V[:], p.A[:] = u[p.held_dofs], vel[p.held_dofs], acc[p.held_dofs]
    scheme.step(0.0)
    u1 = u + dt * vel + dt * dt / 2 * acc
    a1 = -minv * (K @ u1)
    v1 = vel + dt / 2 * (acc + a1)
    for p in parts:
        d = p.held_dofs[:p.n_own]
        for got, want in ((p.U, u1), (p.V, v1), (p.A, a1)):
            assert np.abs(got[:p.n_own] - want[d]).max() < 1e-12 * np.abs(want[d]).max()
    asm.destroy()


def test_spectral_radius_of_the_sub_cycled_step(tmp_path):
    """One system step as a matrix (solver.coupling.analysis): at FE step ratio 4
    and omega_fe * fdt = 1.0 the damped scheme (damping ratio 0.027 at the DEM's
    highest frequency) does not amplify; without damping it does."""
    from solver.coupling.analysis import spectral_radius, step_matrix
    radii = {}
    for name, beta_r, nb, wh in (("damped", 1e-9, 0.0, 1.0), ("undamped", 0.0, 0.0, 1.0)):
        probe = built(short_bar(4, 1e-10, beta_r, nb), tmp_path)
        om = probe.scheme.freqs["fem"][0].omega_max
        probe.destroy()
        asm = built(short_bar(4, wh / om / 4, beta_r, nb), tmp_path)
        asm.scheme.initialise(asm.model)
        radii[name] = spectral_radius(step_matrix(asm.scheme, asm.parts))
        asm.destroy()
    assert radii["damped"] <= 1 + 1e-9, radii
    assert radii["undamped"] > 1 + 1e-5, radii


def test_sub_cycling_without_damping_and_beta_are_refused(tmp_path):
    out = tmp_path / "x.h5"
    proc = run_cli(["configs/wave_bar_transition.yaml", "--set", "damping.beta=0",
                    "--set", f"output.file={out}"])
    assert proc.returncode == 2
    line, = proc.stderr.strip().splitlines()
    assert line.startswith("error: damping.beta: 0 s: the transition scheme sub-cycles (FE step 4 "
                           "x the DE step) and needs damping.beta >= 3.71e-10 s"), line
    proc = run_cli(["configs/wave_bar_transition.yaml", "--set", "partitions.fem.beta=0.25",
                    "--set", f"output.file={out}"])
    assert proc.returncode == 2
    assert "partitions[0].beta: 0.25: the transition scheme's FE step is central difference" \
        in proc.stderr
    assert not out.exists()


def bar3d(tet=0, transition=True):
    """The 3D bar of meshes/bar3d_transition.geo: a half-sine push on the left face."""
    raw = {
        "name": "bar3d_transition",
        "time": {"end": 2.4e-6, "dt": 1.0e-8},
        "model": {"kind": "continuum", "mesh": str(CONFIGS_MESH / "bar3d_transition.geo"),
                  "mesh_parameters": {"tet": tet},
                  "material": {"E": 70e9, "nu": 0.25, "rho": 2700.0, "kind": "solid"},
                  "body": "solid", "fixed": ["right"],
                  "lattice": {"region": "dem", "spacing": 2e-4, "transition": "band"}},
        "partitions": [{"name": "fem", "method": "fem", "group": "fem", "integrator": "explicit",
                        "beta": 0.0, "ratio": 2},
                       {"name": "dem", "method": "dem", "group": "dem", "integrator": "verlet",
                        "ratio": 1}],
        "coupling": {"scheme": "transition"},
        "damping": {"beta": 2e-9},
        "loads": [{"group": "left", "kind": "half_sine", "amplitude": 1e6, "duration": 8e-7}],
        "probes": [{"name": "P", "at": [0.0060, 0.0006, 0.0006]},
                   {"name": "M", "at": [0.0040, 0.0006, 0.0006]}],
    }
    if not transition:
        raw["model"].pop("lattice")
        raw["coupling"] = {"scheme": "overlap"}
        raw["partitions"] = [dict(raw["partitions"][0], group="solid", ratio=1)]
        raw["time"]["dt"] = 2.0e-8
    return raw


CONFIGS_MESH = __import__("conftest").ROOT / "meshes"


def assert_rigid_motions_exert_nothing(mdl):
    """The 3D model's stiffness maps its six rigid motions to zero (1e-9)."""
    K = full_stiffness(mdl)
    x, y, z = mdl.points.T
    one, zero = np.ones_like(x), np.zeros_like(x)
    scale = np.abs(K).max()
    for u in ([one, zero, zero], [zero, one, zero], [zero, zero, one], [-y, x, zero],
              [zero, -z, y], [z, zero, -x]):
        assert np.abs(K @ np.stack(u, 1).ravel()).max() < 1e-9 * scale


@pytest.mark.parametrize("tet", [0, 1])
def test_3d_transition_zone(tet, tmp_path):
    """hex8 and tet4 bands around a simple cubic lattice: the mass is rho V to
    round-off, rigid motions (translations, rotations) exert no force, and the
    push that crossed the DEM region arrives beyond it as in the FEM-only run
    on the same mesh (peak velocity within 5 %)."""
    bound, mdl = model_of(bar3d(tet), tmp_path)
    assert abs(mdl.mass.sum() - 2700.0 * 0.008 * 0.0012 ** 2) < 1e-12 * mdl.mass.sum()
    assert_rigid_motions_exert_nothing(mdl)
    coupled = run_scene(bar3d(tet), tmp_path)
    fem = run_scene(bar3d(tet, transition=False), tmp_path)
    assert coupled.probes["M"]["attrs"]["partition"] == "dem"
    v_c, v_f = coupled.probes["P"]["velocity"], fem.probes["P"]["velocity"][::1]
    peak = np.abs(v_f).max()
    assert peak > 0
    assert abs(np.abs(v_c).max() - peak) < 0.05 * peak


def test_fields_show_fe_and_band_cells_and_the_particles(tmp_path):
    """Field output of a transition run: the mesh file holds the FE and band
    cells (with their stress), the particle file the core particles."""
    import meshio
    raw = raw_scene("wave_bar_transition")
    raw["time"]["end"] = 1.9992e-5                                # 357 system steps
    raw["output"] = {"file": str(tmp_path / "f.h5"), "fields": {"every": 100}, "progress": 0}
    proc = run_cli([write_scene(tmp_path / "f.yaml", raw)])
    assert proc.returncode == 0, proc.stderr
    with meshio.xdmf.TimeSeriesReader(str(tmp_path / "f_fields.xdmf")) as r:
        points, cells = r.read_points_cells()
        t, point_data, cell_data = r.read_data(r.num_steps - 1)
    assert sum(len(c.data) for c in cells) == 1188 + 6          # FE cells + band cells
    assert all(np.isfinite(s).all() for s in cell_data["stress"])
    assert np.abs(point_data["displacement"]).max() > 0
    with meshio.xdmf.TimeSeriesReader(str(tmp_path / "f_particles.xdmf")) as r:
        points, cells = r.read_points_cells()
    assert len(points) == 143                                     # 11 x 13 core particles


def test_monolithic_reference_of_a_transition_scene(tmp_path):
    """reference: monolithic runs the whole model (FE cells, carried and lattice
    bonds) as one explicit partition: the transition run at FE step = DE step
    matches it at A, B and C once the pulse has crossed the DEM region."""
    raw = raw_scene("wave_bar_transition")
    raw["time"] = {"end": 4.9994e-5, "dt": 1.4e-8}                # 3571 steps
    raw["partitions"][0]["ratio"] = 1
    raw["reference"] = {"kind": "monolithic", "dt": 7e-9, "cache": False}
    res = run_scene(raw, tmp_path)
    for name in "ABC":
        assert res.probes[name]["attrs"]["max_rel_error"] < 2e-3, (name, res.probes[name]["attrs"])


def test_3d_transition_zone_on_a_random_packing(tmp_path):
    """model.lattice.kind random in a hex8 band: the particles' and band
    nodes' mass is rho V to round-off, rigid motions exert no force, and the
    push arrives beyond the DEM region as in the FEM-only run (peak velocity
    within 5 %).  The tet4 band's cells are smaller than the particles: 29 of
    them hold none, which is refused, naming one."""
    raw = bar3d(0)
    raw["model"]["lattice"].update(kind="random", seed=2)
    bound, mdl = model_of(raw, tmp_path)
    assert abs(mdl.mass.sum() - 2700.0 * 0.008 * 0.0012 ** 2) < 1e-12 * mdl.mass.sum()
    assert_rigid_motions_exert_nothing(mdl)
    coupled = run_scene(raw, tmp_path)
    fem = run_scene(bar3d(0, transition=False), tmp_path)
    v_c, v_f = coupled.probes["P"]["velocity"], fem.probes["P"]["velocity"]
    peak = np.abs(v_f).max()
    assert abs(np.abs(v_c).max() - peak) < 0.05 * peak, (np.abs(v_c).max(), peak)

    raw = bar3d(1)
    raw["model"]["lattice"].update(kind="random", seed=2)
    with pytest.raises(SceneError, match=r"band cell gmsh element \d+ of group 'band' holds no "
                                         r"particle of the random packing \(radius 0\.0001 m; "
                                         r"29 such cells\)"):
        model_of(raw, tmp_path)
