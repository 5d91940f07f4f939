"""What a run writes for viewers, plots and audits: XDMF fields as one time
series ending at the final state (read back with VTK's reader), the damping's
dissipation in the energy audit of every damped scheme, the conserving
scheme's interface acceleration, and the plot and sweep tools on scenes
without probes and on continua."""
import csv
import os
import subprocess
import sys
import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest

from conftest import ROOT, built, raw_scene, run_cli, run_scene, write_scene


def vtk_reader():
    """VTK's XDMF reader (ParaView's and pyvista's), or skip."""
    try:
        from vtkmodules.vtkIOXdmf2 import vtkXdmfReader
    except ImportError:
        pytest.skip("vtk is not importable (requirements.txt pins it)")
    return vtkXdmfReader


def frames(path):
    """(times, [(point data, cell data, n_points)] per time) of ``path`` as VTK's
    XDMF reader gives them; asserts every time step is one dataset (no blocks)."""
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline as SDDP
    reader = vtk_reader()()
    reader.SetFileName(str(path))
    reader.UpdateInformation()
    info = reader.GetOutputInformation(0)
    times = np.array(info.Get(SDDP.TIME_STEPS())) if info.Has(SDDP.TIME_STEPS()) else np.zeros(0)
    out = []
    for t in (times if times.size else [None]):
        if t is None:
            reader.Update()
        else:
            reader.UpdateTimeStep(t)
        data = reader.GetOutputDataObject(0)
        assert not data.IsA("vtkCompositeDataSet"), (path, data.GetClassName())
        pd, cd = data.GetPointData(), data.GetCellData()
        out.append(({pd.GetArrayName(i): vtk_to_numpy(pd.GetArray(i)).copy()
                     for i in range(pd.GetNumberOfArrays())},
                    {cd.GetArrayName(i): vtk_to_numpy(cd.GetArray(i)).copy()
                     for i in range(cd.GetNumberOfArrays())}, data.GetNumberOfPoints()))
    return times, out


def one_collection(path) -> int:
    """The XDMF's Domain holds one temporal collection and nothing else; its steps."""
    domain = ET.parse(path).getroot().find("Domain")
    grid, = list(domain)
    assert (grid.tag, grid.get("GridType"), grid.get("CollectionType")) == \
        ("Grid", "Collection", "Temporal")
    steps = grid.findall("Grid")
    assert all(s.get("GridType") == "Uniform" for s in steps)
    return len(steps)


# ------------------------------------------------------------------ 1, 2: fields
def test_fields_are_one_time_series_ending_at_the_final_state(tmp_path):
    """wave_bar_fem, 37 system steps, fields every 10: VTK's reader sees one
    dataset per time (no static mesh block), at t = 0, 10, 20, 30 and 37 steps
    (the end state, not the last multiple of every), and the displacement at
    each probe node equals the probe history at that step (the bar deforms)."""
    raw = raw_scene("wave_bar_fem")
    dt = raw["time"]["dt"]
    raw["time"]["end"] = 37 * dt
    raw["reference"] = "none"
    raw["probes"] = [{"name": "L", "at": [0.0, 0.0012]},
                     {"name": "Ly", "at": [0.0008, 0.0024], "component": 1}]
    raw["output"] = {"fields": {"every": 10}}
    res = run_scene(raw, tmp_path)
    xdmf = tmp_path / "wave_bar_fem_fields.xdmf"
    assert one_collection(xdmf) == 5
    times, data = frames(xdmf)
    steps = [0, 10, 20, 30, 37]
    assert np.allclose(times, np.array(steps) * dt, rtol=1e-12, atol=0)
    for name in ("L", "Ly"):
        pr = res.probes[name]
        node, comp = int(pr["attrs"]["node"]), int(pr["attrs"]["component"])
        seen = np.array([point["displacement"][node, comp] for point, _, _ in data])
        assert np.array_equal(seen, pr["displacement"][steps]), (name, seen)
        assert abs(seen[-1]) > 1e-3 * np.abs(pr["displacement"]).max() > 0
    point, cell, n = data[-1]
    assert n == len(point["displacement"]) and cell["stress"].shape[1] == 9


def test_particles_and_cracks_read_as_single_datasets(tmp_path):
    """A bonded lattice that cracks (Zhang et al.'s (2009) bar, breakable nonlinear bonds,
    pulled): the particle XDMF is one time series whose last frame is the end
    state, with the probed particle's displacement equal to its history and
    damage > 0 on exactly the particles of the broken bonds; the cracks XDMF is
    one dataset of every broken bond with the time it broke."""
    raw = raw_scene("wave_bar_transition")
    raw["model"]["lattice"].update(geometry="nonlinear", break_strain=3e-4)
    raw["partitions"][0]["ratio"] = 1
    raw["damping"] = {"beta": 0.0}
    raw["loads"][0]["direction"] = [-1.0, 0.0]
    dt = raw["time"]["dt"]
    n_sys = 2430
    raw["time"]["end"] = n_sys * dt
    raw["reference"] = "none"
    raw["probes"] = [{"name": "F", "at": [0.159, 0.0012]}]          # on the crack's face
    raw["output"] = {"fields": {"every": 1000}}
    res = run_scene(raw, tmp_path)
    assert res.attrs["n_system_steps"] == n_sys and len(res.broken)
    first_break = res.broken[0, 0]
    assert first_break > 2000 * dt            # the last multiple of every precedes it
    particles = tmp_path / "wave_bar_transition_particles.xdmf"
    assert one_collection(particles) == 4
    times, data = frames(particles)
    assert np.allclose(times, np.array([0, 1000, 2000, n_sys]) * dt, rtol=1e-12, atol=0)
    from solver.model.binding import bind
    from solver.model.binding import from_dict
    scene = bind(from_dict({**raw, "output": {"file": str(tmp_path / "x.h5")}}))
    ids = np.array(sorted(next(p for p in scene.partitions if p.method == "dem").nodes))
    pr = res.probes["F"]
    at = int(np.searchsorted(ids, pr["attrs"]["node"]))
    seen = np.array([point["displacement"][at, 0] for point, _, _ in data])
    assert np.array_equal(seen, pr["displacement"][[0, 1000, 2000, n_sys]])
    damaged = ids[data[-1][0]["damage"] > 0]
    assert np.array_equal(damaged, np.unique(res.broken[:, -2:].astype(int)))
    assert not data[-2][0]["damage"].any()         # the frame before the first break
    cracks = tmp_path / "wave_bar_transition_cracks.xdmf"
    _, ((point, _, n),) = frames(cracks)
    assert n == len(res.broken)
    assert np.array_equal(np.sort(point["time"]), res.broken[:, 0])


def test_a_failed_run_writes_the_state_it_stopped_at(tmp_path):
    """wave_bar_fem at 2e-7 s (critical 1.1e-7 s, guard.stable_step off) blows up
    and stops at system step 4, before the first multiple of fields.every = 7:
    its fields still end with that state (t = 8e-7 s, the output's t_end)."""
    out = tmp_path / "f.h5"
    proc = run_cli(["configs/wave_bar_fem.yaml", "--set", f"output.file={out}", "--set",
                    "time.dt=2e-7", "--set", "guard.stable_step=false", "--set",
                    "output.fields.every=7", "--set", "reference=none"])
    assert proc.returncode == 3, proc.stderr
    with h5py.File(out) as f:
        assert f.attrs["status"] == "failed"
        t_end, n = float(f.attrs["t_end"]), int(f.attrs["n_system_steps"])
    assert 0 < n < 7
    xdmf = tmp_path / "f_fields.xdmf"
    assert one_collection(xdmf) == 2
    times, data = frames(xdmf)
    assert np.allclose(times, [0.0, t_end], rtol=1e-12, atol=0)
    assert np.abs(data[-1][0]["displacement"]).max() > 0


# ------------------------------------------------------------- 3: energy audit
def audit(energy):
    """(largest |E(t) + D(t) - E(0) - W(t)| / (E(0) + max |W|), D(end) / the same)."""
    e0 = energy["total"][0]
    gap = energy["total"] + energy["dissipated"] - e0 - energy["external_work"]
    scale = e0 + np.abs(energy["external_work"]).max()
    return float(np.abs(gap).max() / scale), float(energy["dissipated"][-1] / scale)


def six_dof_damped(partitions=None, dt=0.004, end=20.0, alpha=0.05, beta=0.02, **extra):
    raw = raw_scene("six_dof")
    raw["time"] = {"end": end, "dt": dt}
    if partitions is not None:
        raw["partitions"] = partitions
    raw["damping"] = {"alpha": alpha, "beta": beta}
    raw["reference"] = "none"
    raw["output"] = {"energy_every": 1}
    raw.update(extra)
    return raw


def whole(method, integrator):
    return [{"name": "all", "method": method, "nodes": list(range(6)), "integrator": integrator,
             "ratio": 1, **({"beta": 0.0} if integrator == "explicit" else {})}]


def five_node_damped(scheme):
    raw = raw_scene("five_node")
    raw["damping"] = {"alpha": 0.05, "beta": 0.002}
    raw["coupling"] = {"scheme": scheme}
    raw["reference"] = "none"
    raw["output"] = {"energy_every": 1}
    return raw


# (scene, tolerance): E + D = E(0) + W to the stated fraction of E(0) + max |W|
# (measured in brackets).  The dissipation is h v.C v per step at the velocity
# the residual uses, second order in the step; the explicit and Verlet rows are
# also limited by the O((omega h)^2) wobble of their kinetic + strain energy
# (what they conserve is a shadow energy), the coupled rows by the coupling's
# own interface energy error.
AUDITS = {
    "explicit": (lambda: six_dof_damped(whole("fem", "explicit")), 1e-4),     # 4.3e-5
    "implicit": (lambda: six_dof_damped(whole("fem", "implicit")), 5e-5),     # 1.3e-5
    "verlet": (lambda: six_dof_damped(whole("dem", "verlet")), 2e-4),         # 7.7e-5
    "overlap": (lambda: six_dof_damped(), 1e-3),                             # 3.0e-4
    "staggered": (lambda: five_node_damped("staggered"), 1e-6),              # 1.0e-7
    "gc": (lambda: five_node_damped("gc"), 2e-4),                            # 8.4e-5
}


@pytest.mark.parametrize("case", sorted(AUDITS))
def test_damped_energy_audit_balances(case, tmp_path):
    make, tol = AUDITS[case]
    res = run_scene(make(), tmp_path)
    gap, dissipated = audit(res.energy)
    assert dissipated > 0.05, dissipated               # damping took a real share
    assert gap < tol, (gap, dissipated)


def test_damped_conserving_chain_audit_balances(tmp_path):
    """The conserving scheme with Rayleigh damping on both sides, 40-mass chain
    at m = 4, coarse step 0.25 s: E + D = E(0) + W to 1e-3 (3.3e-4 measured,
    second order: 5.5e-3 at 1 s, 5.3e-5 at 0.1 s).  The fine side replays its
    pass on the solved interface path, so its dissipation is the true path's
    (superposing the free pass's would leave 17 % out), and the replay moves
    the same way as the superposed response (to round-off)."""
    from test_conserving import chain
    raw = chain(4, dT=0.25, end=150.0)
    raw["damping"] = {"alpha": 0.01, "beta": 0.05}
    raw["reference"] = "none"
    raw["output"] = {"energy_every": 1}
    res = run_scene(raw, tmp_path)
    gap, dissipated = audit(res.energy)
    assert dissipated > 0.5 and gap < 1e-3, (gap, dissipated)
    states = []
    for replay in (True, False):
        asm = built(raw, tmp_path)
        asm.scheme.replay = replay
        for s in range(200):
            asm.scheme.step(s * 0.25)
        states.append(np.concatenate([p.state[:2].ravel() for p in asm.parts]))
        asm.destroy()
    assert np.abs(states[0] - states[1]).max() < 1e-12 * np.abs(states[1]).max()


def test_continuum_audits_balance(tmp_path):
    """Explicit FE (wave_bar_fem with Rayleigh damping, 4.3e-6 measured) and the
    transition band (wave_bar_transition as published, beta = 2e-8 s: its total
    energy ends 8.6 % below the work, which the dissipation now accounts for,
    to 4.0e-4)."""
    fem = raw_scene("wave_bar_fem")
    fem["time"]["end"] = 2.0e-5
    fem["damping"] = {"alpha": 2.0e4, "beta": 2.0e-9}
    fem["reference"] = "none"
    fem["output"] = {"energy_every": 5}
    tra = raw_scene("wave_bar_transition")
    tra["reference"] = "none"
    tra["output"] = {"energy_every": 5}
    for raw, tol, share in ((fem, 5e-5, 0.2), (tra, 1e-3, 0.08)):
        res = run_scene(raw, tmp_path)
        gap, dissipated = audit(res.energy)
        assert dissipated > share and gap < tol, (raw["name"], gap, dissipated)


# ------------------------------------------- 4: the conserving scheme's interface
def test_conserving_interface_acceleration_is_newtons_and_smooth(tmp_path, monkeypatch):
    """40-mass chain (k = m = 1) at m = 2, fine step 0.9 s (0.9 x its critical
    step), coarse step T = 1.8 s.  The coarse interface node's recorded
    acceleration is Newton's at the system step's end: the forces of both
    sides at the recorded displacements over its mass, u_19 - 2 u_20 + u_21, to
    round-off (the recursion's own value was off by up to 0.024, zig-zagging
    every step).  It changes by less than 0.015 per system step (0.0119
    measured; the recursion's 0.047).  Its consistency with the velocity: the
    trapezoidal rule of the recorded accelerations plus the difference of the
    step's mean interface force Lambda from the mean of its end forces gives
    (v_n+1 - v_n) / T exactly (that difference stays below 8e-3, 5.7e-3 measured).  u and v are
    the recursion's to round-off (its interface force is a null mode of the
    average-acceleration update)."""
    from solver.coupling.conserving import Conserving
    from test_conserving import chain
    T = 1.8

    def history(regauge=True):
        if not regauge:
            monkeypatch.setattr(Conserving, "_regauge", lambda self, G: None)
        asm = built(chain(2, dT=T), tmp_path)
        scheme, F, C = asm.scheme, asm.scheme.F, asm.scheme.C
        i19, i20, i21 = F.local_index(19, 0), C.local_index(20, 0), C.local_index(21, 0)
        rows = [(C.A[i20], C.V[i20], C.U[i20], F.U[i19] - 2 * C.U[i20] + C.U[i21],
                 scheme.G0[0], np.nan)]
        for s in range(300):
            scheme.step(s * T)
            rows.append((C.A[i20], C.V[i20], C.U[i20], F.U[i19] - 2 * C.U[i20] + C.U[i21],
                         scheme.G0[0], scheme.Lambda[0]))
        asm.destroy()
        monkeypatch.undo()
        return np.array(rows)

    new, old = history(), history(regauge=False)
    a, v, u, newton, G, lam = new.T
    assert np.abs(a - newton).max() < 1e-12, np.abs(a - newton).max()
    assert np.abs(old[:, 0] - old[:, 3]).max() > 0.02          # what it replaces
    assert np.abs(np.diff(a)).max() < 0.015, np.abs(np.diff(a)).max()
    assert np.abs(np.diff(old[:, 0])).max() > 0.04
    gap = lam[1:] - 0.5 * (G[1:] + G[:-1])                   # interface mass 1
    mean = (v[1:] - v[:-1]) / T
    assert np.abs(mean - 0.5 * (a[1:] + a[:-1]) - gap).max() < 1e-14
    assert np.abs(gap).max() < 8e-3, np.abs(gap).max()
    assert np.abs(new[:, 1:3] - old[:, 1:3]).max() < 1e-12 * np.abs(old[:, 2]).max()


# --------------------------------------------------------------- 5, 6: tools
def tool(module, *args, timeout=600):
    return subprocess.run([sys.executable, "-m", f"solver.tools.{module}", *map(str, args)],
                          cwd=ROOT, capture_output=True, text=True, timeout=timeout,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})


def test_sweep_without_probes_is_refused_in_one_line(tmp_path):
    raw = raw_scene("six_dof")
    raw["probes"] = []
    raw["reference"] = "none"
    scene = write_scene(tmp_path / "np.yaml", raw)
    proc = tool("sweep", scene, "--ratios", "1,2", "--out", tmp_path / "sw")
    assert proc.returncode == 2, proc.stderr
    line, = proc.stderr.strip().splitlines()
    assert line == (f"error: {scene}: probes: the scene has none; the sweep measures the error "
                    "at probes (add some under probes:)")
    assert not (tmp_path / "sw").exists()


def test_plot_without_probes_and_into_a_new_directory(tmp_path):
    """laser_disc (heat only, no probes) plots its temperatures (its energies
    are zero: no panel for them);
    -o into a missing directory creates it; -o under a file is one line, exit 2."""
    out = tmp_path / "disc.h5"
    proc = run_cli(["configs/laser_disc.yaml", "--set", f"output.file={out}", "--set",
                    "time.end=1.0e-6"])
    assert proc.returncode == 0, proc.stderr
    png = tmp_path / "new" / "dir" / "disc.png"
    proc = tool("plot", out, "-o", png)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == f"wrote {png}" and png.stat().st_size > 20000
    from solver.tools.plot import panels_of
    with h5py.File(out) as f:
        assert "probes" not in f
        energy = {k: f["energy"][k][()] for k in f["energy"]}
        heat = {k: f["heat"][k][()] for k in f["heat"]}
    assert panels_of({}, energy, heat) == ["heat"]            # its energies are all zero
    (tmp_path / "file").write_text("x")
    proc = tool("plot", out, "-o", tmp_path / "file" / "p.png")
    assert proc.returncode == 2
    line, = proc.stderr.strip().splitlines()
    assert line.startswith(f"error: -o {tmp_path / 'file' / 'p.png'}: cannot create its directory")


def test_sweep_on_a_continuum_uses_every_probe(tmp_path):
    """wave_bar_fem (probes A, B, C against the 1D bar wave): eq. 9 over all
    three probes as one vector, the worst probe's max and RMS errors, their
    normalisation stated in the table; the plot and a run's plot are written."""
    from solver.driver.comparison import vector_error
    proc = tool("sweep", "configs/wave_bar_fem.yaml", "--dts", "1e-8,2e-8", "--set",
                "time.end=4e-5", "--out", tmp_path)
    assert proc.returncode == 0, proc.stderr
    rows = list(csv.DictReader(open(tmp_path / "sweep.csv")))
    assert len(rows) == 2
    for r in rows:
        with h5py.File(tmp_path / "runs" / f"n1_overlap_taylor_dt{float(r['dt'])}.h5") as f:
            probes = {n: g for n, g in f["probes"].items()}
            assert sorted(probes) == ["A", "B", "C"]
            worst = max(g.attrs["max_rel_error"] for g in probes.values())
            rms = max(g.attrs["rms_rel_error"] for g in probes.values())
            eq9 = vector_error(np.array([probes[n]["displacement"][()] for n in "ABC"]),
                               np.array([probes[n]["reference_displacement"][()] for n in "ABC"]))
            assert float(r["max_rel_error"]) == pytest.approx(worst, rel=1e-12)
            assert float(r["rms_rel_error"]) == pytest.approx(rms, rel=1e-12)
            assert float(r["vector_rel_error"]) == pytest.approx(eq9, rel=1e-12)
            assert f.attrs["vector_rel_error"] == pytest.approx(eq9, rel=1e-12)
            assert 0 < eq9 < 0.02                       # 6.9e-3 at dt 1e-8
    md = (tmp_path / "sweep.md").read_text()
    assert "- max rel. error: worst probe: max|u − u_ref| / max|u_ref|" in md
    assert "- eq. 9 error: all probes as one vector" in md
    assert (tmp_path / "sweep.png").stat().st_size > 20000
    run = tmp_path / "runs" / "n1_overlap_taylor_dt1e-08.h5"
    proc = tool("plot", run, "-o", tmp_path / "run.png")
    assert proc.returncode == 0, proc.stderr
    from solver.tools.plot import panels_of
    with h5py.File(run) as f:
        probes = {n: {k: g[k][()] for k in g} | {"attrs": dict(g.attrs)} for n, g in f["probes"].items()}
        energy = {k: f["energy"][k][()] for k in f["energy"]}
    assert panels_of(probes, energy, {}) == ["displacement", "error", "stress", "energy"]
