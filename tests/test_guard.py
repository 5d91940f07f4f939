"""Unstable steps are refused before stepping; blow-ups stop the run at once."""
import h5py
import numpy as np
import pytest

from conftest import raw_scene, run_cli, write_scene


def test_unstable_step_is_refused_before_stepping(tmp_path):
    raw = raw_scene("six_dof")
    out = tmp_path / "out.h5"
    raw["output"] = {"file": str(out)}
    raw["time"]["dt"] = 0.3            # fem steps 1.5 s; its critical step is 2/omega_max ~ 1.04 s
    raw["time"]["end"] = 21.0          # 14 system steps
    proc = run_cli([write_scene(tmp_path / "s.yaml", raw)])
    assert proc.returncode == 2, proc.stderr
    line, = proc.stderr.strip().splitlines()
    assert "partition 'fem'" in line and "step 1.5 s" in line
    assert "critical step 1.0" in line and "Traceback" not in proc.stderr
    assert "[solver] t =" not in proc.stdout and not out.exists()


def _blowup(tmp_path, bound):
    raw = raw_scene("six_dof")
    raw["time"] = {"end": 2000.0, "dt": 0.25}   # fem at ratio 5: 1.25 s > critical step
    raw["guard"] = {"stable_step": False, "energy_bound": bound}
    raw["output"] = {"file": str(tmp_path / "out.h5"), "energy_every": 1}
    raw["reference"] = "none"
    return run_cli([write_scene(tmp_path / "s.yaml", raw)]), tmp_path / "out.h5"


def test_energy_growth_stops_the_run_and_marks_the_file(tmp_path):
    proc, out = _blowup(tmp_path, 10.0)
    assert proc.returncode == 3, proc.stderr
    assert "warning: partition 'fem'" in proc.stdout and "running anyway" in proc.stdout
    line, = proc.stderr.strip().splitlines()
    assert "energy grew" in line and "guard.energy_bound" in line and "marked failed" in line
    with h5py.File(out) as f:
        assert f.attrs["status"] == "failed" and "energy grew" in f.attrs["message"]
        n = f.attrs["n_system_steps"]
        assert 0 < n < 1600                       # stopped early, at the first check
        assert f["probes/x3/t"].shape == (n + 1,)


def test_non_finite_state_stops_the_run(tmp_path):
    proc, out = _blowup(tmp_path, 1e300)           # energy bound out of the way: NaN/inf path
    assert proc.returncode == 3, proc.stderr
    assert "non-finite state" in proc.stderr
    with h5py.File(out) as f:
        assert f.attrs["status"] == "failed" and "non-finite" in f.attrs["message"]


@pytest.mark.parametrize("name", ["bar3d", "metamaterial"])
def test_lanczos_estimate_is_the_exact_omega_raised_by_its_margin(name, monkeypatch):
    """Above EXACT_LIMIT DOFs omega_max comes from Lanczos (or the Gershgorin
    bound where that is lower): never below the dense eigenvalue, and within
    the stated margin above it."""
    from conftest import raw_scene
    from solver.model import layout as overlap
    from solver.model import arrays
    from solver.partitions import stability
    from solver.model.binding import from_dict
    scene = from_dict(raw_scene(name))
    mdl = arrays.build(scene, [1] * len(scene.partitions))
    layouts = overlap.derive(mdl.graph(), scene.partitions, [1] * len(scene.partitions))
    dm = mdl.dofmap
    for spec, lay in zip(scene.partitions, layouts):
        held = lay.held
        blocks = mdl.bond_blocks(held) if spec.method == "dem" else mdl.stiffness_blocks(held)
        mass = np.where(mdl.fixed[dm.dofs(held)], np.inf, np.repeat(mdl.mass[held], dm.counts[held]))
        assert stability.EXACT_LIMIT < mass.size <= stability.DENSE_LIMIT
        fast = stability.omega_max(blocks, held, mass, dm)
        monkeypatch.setattr(stability, "EXACT_LIMIT", 10**9)
        exact = stability.omega_max(blocks, held, mass, dm)
        monkeypatch.undo()
        assert fast.method in ("Lanczos", "Gershgorin bound") and exact.method == "exact"
        ratio = fast.omega_max / exact.omega_max
        assert 1.0 <= ratio <= 1 / np.sqrt(1 - stability.LANCZOS_EPS) + 1e-9, (spec.name, ratio)
