"""Continuum FEM from gmsh meshes: the wave_bar against the 1D analytic wave,
coupled continuum partitions, 1 vs 2 ranks, and scene errors."""
import numpy as np
import pytest

from conftest import ROOT, raw_scene, run_cli, run_scene, write_scene

E, RHO, THICK, Q, T = 70e9, 2700.0, 3.2e-4, 1.0e4, 1.5e-5
C = np.sqrt(E / RHO)
V0 = (Q / THICK) / (RHO * C)          # particle velocity of the 1D wave


def half_rise(t, v):
    peak = v.max()
    k = int(np.argmax(v >= 0.5 * peak))
    return t[k - 1] + (0.5 * peak - v[k - 1]) / (v[k] - v[k - 1]) * (t[k] - t[k - 1]), peak


@pytest.mark.parametrize("scene", ["wave_bar_fem", "wave_bar_3d"])
def test_wave_bar_fem_matches_the_1d_wave(scene, tmp_path):
    res = run_scene(raw_scene(scene), tmp_path)
    assert res.partitions["fem"]["steps"] == 2750
    for name, x in (("A", 0.078), ("B", 0.160), ("C", 0.242)):
        pr = res.probes[name]
        arrival, peak = half_rise(pr["t"], pr["velocity"])
        arrival -= T / 6                   # a half-sine reaches half its peak at T/6
        assert abs(arrival / (x / C) - 1) < 0.01, (name, arrival, x / C)
        assert abs(peak / V0 - 1) < 0.05, (name, peak, V0)
        # the scene's bar_wave reference: displacement against the 1D solution
        assert pr["attrs"]["rms_rel_error"] < 0.01, (name, pr["attrs"])


def split_bar(tmp_path, eta=2, end=1.2e-5):
    raw = raw_scene("wave_bar_fem")
    raw["name"] = "bar_split"
    raw["time"] = {"end": end, "dt": 1e-8}
    raw["model"]["mesh"] = str(ROOT / "meshes" / "bar_split.geo")
    raw["partitions"] = [
        {"name": "west", "method": "fem", "group": "west", "integrator": "explicit", "ratio": eta},
        {"name": "east", "method": "fem", "group": "east", "integrator": "explicit", "ratio": 1}]
    raw["probes"] = [{"name": "mid", "at": [0.024, 0.0012]}, {"name": "w", "at": [0.008, 0.0008]}]
    return raw


def test_coupled_continuum_partitions_match_a_single_one(tmp_path):
    coupled = run_scene(split_bar(tmp_path), tmp_path)
    raw = split_bar(tmp_path)
    raw["partitions"] = [{"name": "all", "method": "fem", "group": "solid",
                          "integrator": "explicit", "ratio": 1}]
    raw["name"] = "bar_single"
    single = run_scene(raw, tmp_path)
    assert coupled.partitions["west"]["n_external"] > 0 and coupled.partitions["west"]["steps"] == 600
    for probe in ("mid", "w"):
        a = coupled.probes[probe]["velocity"]
        b = single.probes[probe]["velocity"][::2]
        assert np.abs(b).max() > 0.5 * V0
        assert np.abs(a - b).max() < 0.02 * np.abs(b).max(), probe


def test_continuum_errors(tmp_path):
    cases = [
        (("model", "fixed"), ["nope"], "model.fixed: mesh has no physical group 'nope'; it has: left"),
        (("model", "material"), {"E": 70e9, "nu": 0.33, "rho": 2700.0, "kind": "solid"},
         "model.material.kind: solid does not fit a 2D mesh"),
        (("reference",), "modal", "reference: modal references are for network models"),
        (("reference",), {"kind": "bar", "length": 0.32}, "reference.kind: 'bar' is not one of"),
        # relative to the scene file's directory
        (("model", "mesh"), "meshes/nope.geo",
         f"model.mesh: {tmp_path / 'meshes' / 'nope.geo'}: mesh file not found"),
    ]
    for path, value, message in cases:
        raw = raw_scene("wave_bar_fem")
        node = raw
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = value
        proc = run_cli([write_scene(tmp_path / "s.yaml", raw)])
        assert proc.returncode == 2, (path, proc.stderr)
        assert message in proc.stderr, proc.stderr


COARSE = {"a": 4e-4}


def coupled_bar(**over):
    raw = raw_scene("wave_bar")
    raw["model"]["mesh_parameters"] = dict(COARSE)
    raw["model"]["lattice"]["spacing"] = COARSE["a"]
    raw["time"]["dt"] = 4e-8
    for path, value in over.items():
        node = raw
        *head, last = path.split("__")
        for key in head:
            node = node[key] if not key.isdigit() else node[int(key)]
        node[last] = value
    return raw


@pytest.mark.parametrize("integrator,eta,scheme", [("explicit", 1, "overlap"),
                                                   ("implicit", 2, "staggered")])
def test_coupled_wave_bar_matches_the_1d_wave(integrator, eta, scheme, tmp_path):
    raw = coupled_bar(partitions__0__integrator=integrator, partitions__0__ratio=eta,
                      coupling__scheme=scheme)
    raw["time"]["end"] = int(7.5e-5 / (eta * 4e-8) + 1e-9) * eta * 4e-8   # whole system steps
    res = run_scene(raw, tmp_path)
    assert res.probes["B"]["attrs"]["partition"] == "dem"
    assert res.partitions["dem"]["n_owned"] > 0
    assert res.partitions["dem"]["steps"] == int(7.5e-5 / (eta * 4e-8) + 1e-9) * eta
    for name, x in (("A", 0.078), ("B", 0.160), ("C", 0.242)):
        pr = res.probes[name]
        arrival, peak = half_rise(pr["t"], pr["velocity"])
        assert abs((arrival - T / 6) / (x / C) - 1) < 0.01, name
        assert abs(peak / V0 - 1) < 0.05, name
    t, v = res.probes["A"]["t"], res.probes["A"]["velocity"]
    incident = (t >= 10e-6) & (t <= 32e-6)
    after = (t > 32e-6) & (t <= 77e-6)      # left-going waves before the free-end echo
    reflected = np.trapezoid(v[after] ** 2, t[after]) / np.trapezoid(v[incident] ** 2, t[incident])
    assert reflected < 0.01


def test_lattice_must_coincide_with_the_mesh(tmp_path):
    raw = coupled_bar(model__lattice__spacing=6e-4)
    proc = run_cli([write_scene(tmp_path / "s.yaml", raw)])
    assert proc.returncode == 2
    line, = proc.stderr.strip().splitlines()
    assert "model.lattice:" in line and "have no mesh node within" in line and "(0.1574" in line


def test_lattice_poisson_ratio_is_checked(tmp_path):
    raw = coupled_bar(model__material__nu=0.2)
    proc = run_cli([write_scene(tmp_path / "s.yaml", raw)])
    assert proc.returncode == 2
    assert "model.lattice: a square lattice with diagonal bonds represents nu = 0.333" in proc.stderr


def test_fields_for_paraview_read_back_with_meshio(tmp_path):
    from meshio.xdmf import TimeSeriesReader
    raw = coupled_bar()
    raw["time"]["end"] = 3.0e-5
    raw["output"] = {"file": str(tmp_path / "wb.h5"), "fields": {"every": 125}}
    raw["model"]["mesh"] = str(ROOT / raw["model"]["mesh"])
    elsewhere = tmp_path / "cwd"
    elsewhere.mkdir()
    proc = run_cli([write_scene(tmp_path / "s.yaml", raw)], cwd=elsewhere)
    assert proc.returncode == 0, proc.stderr
    assert list(elsewhere.iterdir()) == []               # nothing lands in the working directory
    assert sorted(p.name for p in tmp_path.iterdir() if p.suffix in (".h5", ".xdmf")) == [
        "wb.h5", "wb_fields.h5", "wb_fields.xdmf", "wb_particles.h5", "wb_particles.xdmf"]
    mesh = TimeSeriesReader(str(tmp_path / "wb_fields.xdmf"))
    points, cells = mesh.read_points_cells()
    parts = TimeSeriesReader(str(tmp_path / "wb_particles.xdmf"))
    ppoints, _ = parts.read_points_cells()
    assert cells[0].type == "quad" and mesh.num_steps == parts.num_steps == 7
    # every particle sits on a mesh node: same place, same motion (one time axis)
    node = np.array([np.argmin(np.linalg.norm(points - p, axis=1)) for p in ppoints])
    assert np.allclose(points[node], ppoints)
    peak = 0.0
    for k in range(mesh.num_steps):
        t, pd, cd = mesh.read_data(k)
        tp, ppd, _ = parts.read_data(k)
        assert t == tp
        assert np.array_equal(pd["velocity"][node], ppd["velocity"])
        peak = max(peak, -cd["stress"][0][:, 0].min())
    assert abs(peak / (Q / THICK) - 1) < 0.05                # compressive pulse q / thickness


def bar3d(coupled, tmp_path):
    """configs/bar3d.yaml (a short 3D bar with a DEM block, nu = 1/4), or the same
    bar with FEM everywhere."""
    raw = raw_scene("bar3d")
    raw["output"] = {"file": str(tmp_path / f"bar3d_{coupled}.h5")}
    if not coupled:
        del raw["model"]["lattice"]
        raw["partitions"] = [{"name": "fem", "method": "fem", "group": "solid",
                              "integrator": "explicit", "ratio": 1}]
    return raw


def test_3d_mesh_lattice_coupling_matches_fem(tmp_path):
    coupled = run_scene(bar3d(True, tmp_path), tmp_path)
    single = run_scene(bar3d(False, tmp_path), tmp_path)
    assert coupled.probes["D"]["attrs"]["partition"] == "dem"
    assert coupled.partitions["dem"]["n_owned"] > 100
    for probe in ("D", "F"):
        a, b = coupled.probes[probe]["velocity"], single.probes[probe]["velocity"]
        assert np.abs(b).max() > 2.0
        assert np.abs(a - b).max() < 0.01 * np.abs(b).max(), probe


@pytest.mark.parametrize("dim", [2, 3])
def test_interface_forces_are_action_and_reaction(dim, tmp_path):
    """The cells with corners on both sides are the same elements in both
    partitions, so the coupling terms are symmetric: K_fem[i, j] = K_dem[j, i]
    for every FEM-owned DOF i and DEM-owned DOF j (as the overlap spring of a
    chain), and the interface cannot create energy."""
    from mpi4py import MPI

    from solver import scene as scene_mod

    from solver.model import binding
    from solver.driver.build import build
    raw = coupled_bar() if dim == 2 else bar3d(True, tmp_path)
    raw["output"] = {"file": str(tmp_path / "o.h5")}
    scene = binding.from_dict(raw)
    fem, dem = build(scene, MPI.COMM_SELF).parts

    def local(part, dofs):
        pos = {d: i for i, d in enumerate(part.held_dofs.tolist())}
        return [pos[d] for d in dofs]
    fem_own = set(fem.held_dofs[:fem.n_own].tolist())
    dem_own = dem.held_dofs[:dem.n_own].tolist()
    rows_f = [d for d in dem.held_dofs[dem.n_own:].tolist() if d in fem_own]   # FEM side of the overlap
    cols_d = [d for d in fem.held_dofs[fem.n_own:].tolist() if d in set(dem_own)]
    assert len(rows_f) > 0 and len(cols_d) > 0
    Kf = -fem.Kneg.getValues(local(fem, rows_f), local(fem, cols_d))
    Kd = -dem.Kneg.getValues(local(dem, cols_d), local(dem, rows_f))
    assert np.abs(Kf).max() > 0
    assert np.allclose(Kf, Kd.T, rtol=1e-12, atol=1e-9 * np.abs(Kf).max())


@pytest.mark.parametrize("eta,warned", [(2, False), (3, True)])
def test_coupled_implicit_step_warning(eta, warned, tmp_path):
    """Coupled implicit steps beyond ~1.4x the explicit critical step were found
    unstable: the run says so before stepping (and the energy guard stays on)."""
    raw = coupled_bar(partitions__0__integrator="implicit", partitions__0__ratio=eta,
                      coupling__scheme="staggered")
    raw["time"]["end"] = 9.6e-7                     # 12 or 8 system steps
    raw["output"] = {"file": str(tmp_path / "o.h5")}
    proc = run_cli([write_scene(tmp_path / "s.yaml", raw)])
    assert proc.returncode == 0, proc.stderr
    assert ("found unstable beyond ~1.4x" in proc.stdout) == warned, proc.stdout


def test_continuum_scene_with_a_monolithic_reference(tmp_path):
    """reference: monolithic on a mesh (it crashed reading scene.model.network)."""
    raw = split_bar(tmp_path, eta=2, end=4e-6)
    raw["reference"] = {"kind": "monolithic", "dt": 1e-8, "integrator": "explicit"}
    res = run_scene(raw, tmp_path)
    for probe in ("mid", "w"):
        at = res.probes[probe]["attrs"]
        ref = res.probes[probe]["reference_displacement"]
        assert np.abs(ref).max() > 0
        assert at["rms_rel_error"] < 0.05, (probe, at)
    assert list((tmp_path / ".reference-cache").glob("*.npz"))


@pytest.mark.parametrize("name", ["wave_bar_3d", "wave_bar_fem"])
def test_xdmf_stress_is_read_by_vtk_as_the_tensor_it_is(name, tmp_path):
    """A uniform strain written as fields and read back with VTK's XDMF reader
    (what ParaView uses): the 3x3 stress VTK builds from Tensor6 equals
    lambda tr(eps) I + 2 mu eps (3D) or the plane-stress tensor (2D, zz = 0)."""
    from mpi4py import MPI
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOXdmf2 import vtkXdmfReader
    from solver.driver.build import build
    from solver.driver.fields import FieldWriter
    from solver.model.binding import from_dict
    raw = raw_scene(name)
    raw["reference"] = "none"
    raw["output"] = {"file": str(tmp_path / "u.h5"), "fields": {"every": 1}}
    scene = from_dict(raw)
    asm = build(scene, MPI.COMM_SELF)
    d = asm.model.dof
    eps = 1e-4 * np.array([[1.0, 0.2, 0.3], [0.2, 2.0, 0.5], [0.3, 0.5, 3.0]])[:d, :d]
    for part in asm.parts:
        part.U[:] = (asm.model.points[part.layout.held] @ eps.T).ravel()
    writer = FieldWriter(scene, asm.model, asm.parts, MPI.COMM_SELF)
    writer.write(0.0)
    writer.close()
    asm.destroy()
    reader = vtkXdmfReader()
    reader.SetFileName(str(tmp_path / "u_fields.xdmf"))
    reader.Update()
    grid = reader.GetOutputDataObject(0)          # one time series: a dataset, not blocks
    stress = vtk_to_numpy(grid.GetCellData().GetArray("stress"))
    E, nu = scene.model.material.E, scene.model.material.nu
    if d == 3:
        lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
        sigma = lam * np.trace(eps) * np.eye(3) + 2 * mu * eps
    else:
        c = E / (1 - nu * nu)
        sigma = np.zeros((3, 3))
        sigma[0, 0] = c * (eps[0, 0] + nu * eps[1, 1])
        sigma[1, 1] = c * (eps[1, 1] + nu * eps[0, 0])
        sigma[0, 1] = sigma[1, 0] = E / (1 + nu) * eps[0, 1]
    assert stress.shape[1] == 9
    assert np.allclose(stress, sigma.ravel(), rtol=1e-9, atol=1e-6 * np.abs(sigma).max())


def test_probe_points_snap_to_body_nodes_and_say_where(tmp_path):
    import h5py
    raw = raw_scene("wave_bar_fem")
    raw["time"]["end"] = 2e-7
    raw["reference"] = "none"
    raw["probes"] = [{"name": "A", "at": [0.0781, 0.0011]}]
    raw["output"] = {"file": str(tmp_path / "p.h5"), "progress": 0}
    proc = run_cli([write_scene(tmp_path / "p.yaml", raw)])
    assert proc.returncode == 0, proc.stderr
    line = next(l for l in proc.stdout.splitlines() if "probe A: at" in l)
    with h5py.File(tmp_path / "p.h5") as f:
        at = f["probes/A"].attrs
        xyz, d, node = at["coordinates"], at["snap_distance"], at["node"]
        assert np.allclose(at["at"], [0.0781, 0.0011])
        assert np.isclose(d, np.linalg.norm(xyz - [0.0781, 0.0011])) and d < 1e-3
    assert f"node {node}" in line and f"{d:.3g} m away" in line
    raw["probes"] = [{"name": "far", "at": [0.5, 0.0012]}]      # the bar ends at 0.32 m
    proc = run_cli([write_scene(tmp_path / "q.yaml", raw)])
    assert proc.returncode == 2
    assert "probes[0].at: [0.5, 0.0012] is" in proc.stderr and "outside the body?" in proc.stderr


def test_paths_in_a_scene_are_relative_to_its_file(tmp_path):
    """A scene in its own folder names its mesh and output relative to itself;
    run from another directory, through ./run.sh, it finds both; --set paths
    are relative to the working directory."""
    import shutil
    import subprocess
    project = tmp_path / "project"
    (project / "geo").mkdir(parents=True)
    shutil.copy(ROOT / "meshes" / "wave_bar.geo", project / "geo" / "bar.geo")
    raw = raw_scene("wave_bar_fem")
    raw["time"]["end"] = 2e-7
    raw["reference"] = "none"
    raw["model"]["mesh"] = "geo/bar.geo"
    raw["output"] = {"file": "out/bar.h5", "progress": 0}
    write_scene(project / "bar.yaml", raw)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    proc = subprocess.run([str(ROOT / "run.sh"), "../project/bar.yaml"], cwd=elsewhere,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert (project / "out" / "bar.h5").is_file() and not (elsewhere / "out").exists()
    proc = run_cli([project / "bar.yaml", "--set", "output.file=here.h5"], cwd=elsewhere)
    assert proc.returncode == 0, proc.stderr
    assert (elsewhere / "here.h5").is_file()
