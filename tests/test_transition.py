"""Seed 003's transition zone: particles inside coarse band cells (issue 9).

The model (masses, carried bonds, stresses) against exact values; the
wave_bar scene against the 1D solution; the step guard naming both sides;
bad input; 1 vs 2 ranks (tests/test_parallel.py runs the MPI side)."""
from __future__ import annotations

import numpy as np
import pytest

from conftest import raw_scene, run_cli, run_scene, write_scene

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
    """The whole model's K (cells, core bonds, carried bonds) as a dense matrix."""
    from solver.partitions.assembly import triplets
    held = np.arange(mdl.n_nodes)
    rows, cols, vals = triplets(mdl.stiffness_blocks(held) + mdl.bond_blocks(held)[:1],
                                mdl.dofmap)
    K = np.zeros((mdl.n_dofs, mdl.n_dofs))
    np.add.at(K, (rows, cols), vals)
    return K


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
    assert np.abs(K - K.T).max() < 1e-9 * np.abs(K).max()
    x, y = mdl.points[:, 0], mdl.points[:, 1]
    scale = np.abs(K).max()
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
    assert res.partitions["fem"]["steps"] * 4 == res.partitions["dem"]["steps"] == 6816
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
                    "--set", f"output.file={out}"])
    assert proc.returncode == 2, proc.stderr
    line, = proc.stderr.strip().splitlines()
    assert "partition 'fem': step 5.5e-08 s (ratio 5" in line
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
    out = tmp_path / "o.h5"
    args = [write_scene(tmp_path / "s.yaml", raw), "--set", f"output.file={out}"]
    for k, v in sets.items():
        args += ["--set", f"{k}={v}"]
    proc = run_cli(args)
    assert proc.returncode == 2, proc.stderr
    line, = proc.stderr.strip().splitlines()
    assert message in line, line
    assert not out.exists()


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
