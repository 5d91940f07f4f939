"""Two ranks: end to end through mpiexec, the in-process MPI tests, launch errors."""
import subprocess
import sys

import h5py
import numpy as np
import pytest

from conftest import ROOT, mpiexec, raw_scene, run_cli, write_scene


@pytest.mark.parametrize("eta", [1, 2, 5, 10, 20])
def test_two_rank_run_matches_one_rank(eta, tmp_path):
    raw = raw_scene("six_dof")
    raw["partitions"][0]["ratio"] = eta
    files = {}
    for n in (1, 2):
        raw["output"] = {"file": str(tmp_path / f"n{n}.h5")}
        proc = run_cli([write_scene(tmp_path / f"s{n}.yaml", raw)], n=n if n > 1 else None)
        assert proc.returncode == 0, proc.stderr
        files[n] = h5py.File(tmp_path / f"n{n}.h5")
    one, two = files[1]["probes/x3/displacement"][()], files[2]["probes/x3/displacement"][()]
    assert files[2].attrs["ranks"] == 2
    assert np.abs(one - two).max() <= 1e-12 * np.abs(one).max()
    for n in (1, 2):                                   # target of the foundation issue
        assert files[n]["probes/x3"].attrs["max_rel_error"] <= 1e-5


def test_in_process_mpi_suite():
    proc = subprocess.run([mpiexec(), "-n", "2", sys.executable, "-m", "pytest", "-q", "-p",
                           "no:cacheprovider", "tests/mpi/mpi_ranks.py"], cwd=ROOT,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert "6 passed" in proc.stdout


def test_launcher_mismatch_is_detected():
    proc = run_cli(["configs/six_dof.yaml"], env={"PMI_SIZE": "2"})
    assert proc.returncode == 4
    assert "world of 1" in proc.stderr and "PMI_SIZE=2" in proc.stderr


def test_rank_count_must_fit_the_partitions(tmp_path):
    raw = raw_scene("six_dof")
    raw["output"] = {"file": str(tmp_path / "o.h5")}
    proc = run_cli([write_scene(tmp_path / "s.yaml", raw)], n=3)
    assert proc.returncode == 4
    assert "2 partitions" in proc.stderr and "not 3" in proc.stderr
    assert not (tmp_path / "o.h5").exists()
