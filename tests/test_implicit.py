"""Implicit FEM partition alone, the staggered scheme, and the linear-solve failure path."""
import numpy as np
import pytest

from conftest import raw_scene, run_cli, run_scene, write_scene


def implicit_alone(dt, end=4.0):
    raw = raw_scene("six_dof")
    raw["name"] = "implicit_alone"
    raw["time"] = {"end": end, "dt": dt}
    raw["partitions"] = [{"name": "all", "method": "fem", "nodes": list(range(6)),
                          "integrator": "implicit", "ratio": 1}]
    return raw


def test_implicit_partition_alone_is_second_order(tmp_path):
    steps = np.array([0.2, 0.1, 0.05])
    errors = [run_scene(implicit_alone(dt), tmp_path).probes["x3"]["attrs"]["rms_rel_error"]
              for dt in steps]
    observed = np.polyfit(np.log(steps), np.log(errors), 1)[0]
    assert abs(observed - 2.0) < 0.1, (observed, errors)


def test_implicit_partition_runs_beyond_the_explicit_limit(tmp_path):
    raw = implicit_alone(1.5, end=60.0)          # omega_max * dt = 2.8 > 2
    res = run_scene(raw, tmp_path)
    assert res.partitions["all"]["critical_step"] == float("inf")
    e = res.energy
    # average acceleration balances energy and the work 1/2 (f_n + f_n+1) du exactly
    assert np.abs(e["total"] - e["external_work"]).max() < 1e-12 * np.abs(e["external_work"]).max()


@pytest.mark.parametrize("eta,limit", [(5, 2.5e-3), (20, 2.5e-2)])
def test_staggered_metamaterial_against_exact_solution(eta, limit, tmp_path):
    raw = raw_scene("metamaterial_implicit")
    raw["partitions"][0]["ratio"] = eta
    raw["reference"] = "modal"
    res = run_scene(raw, tmp_path)
    assert res.attrs["scheme"] == "staggered"
    assert res.probes["p550"]["attrs"]["rms_rel_error"] <= limit
    assert res.partitions["fem"]["steps"] == 75000 // eta


def test_staggered_prescribes_the_explicit_accelerations(tmp_path):
    """After a system step the implicit side's external copies hold the explicit
    side's boundary state at the new time, and vice versa."""
    from mpi4py import MPI

    from solver import scene as scene_mod

    from solver.model import binding
    from solver.driver.build import build
    scene = binding.load("configs/metamaterial_implicit.yaml", ["partitions.fem.ratio=4"])
    asm = build(scene, MPI.COMM_SELF)
    fem, dem = asm.parts
    for s in range(2000):
        asm.scheme.step(s * scene.system_dt)
    for receiver, owner in ((fem, dem), (dem, fem)):
        pos = {n: i for i, n in enumerate(owner.layout.owned.tolist())}
        rows = [pos[n] for n in receiver.layout.external.tolist()]
        assert np.array_equal(receiver.state[:, receiver.n_own:], owner.state[:, rows])
    assert np.abs(dem.A[:dem.n_own]).max() > 0
    assert fem.steps == 2000 and dem.steps == 8000
    asm.destroy()


def test_staggered_needs_one_implicit_partition(tmp_path):
    raw = raw_scene("metamaterial")
    raw["coupling"] = {"scheme": "staggered"}
    proc = run_cli([write_scene(tmp_path / "s.yaml", raw)])
    assert proc.returncode == 2
    assert "coupling.scheme" in proc.stderr and "0 implicit" in proc.stderr


def test_linear_solve_failure_stops_the_run_with_petsc_reason(tmp_path):
    raw = implicit_alone(0.1)
    raw["output"] = {"file": str(tmp_path / "o.h5")}
    proc = run_cli([write_scene(tmp_path / "s.yaml", raw), "-all_ksp_type", "cg",
                    "-all_pc_type", "none", "-all_ksp_max_it", "1", "-all_ksp_rtol", "1e-14"])
    assert proc.returncode == 3, proc.stderr
    line, = proc.stderr.strip().splitlines()
    assert "partition 'all'" in line and "DIVERGED_MAX_IT" in line and "-all_ksp_" in line
