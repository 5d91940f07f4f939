"""A run that fails or is interrupted on any rank ends every rank promptly, with
one error line, the documented exit code and its output kept (status failed,
histories up to the failure); bad launches and PETSc options are one line."""
import os
import signal
import subprocess
import sys

import h5py
import pytest

from conftest import ROOT, mpiexec, raw_scene, run_cli, write_scene

KSP_FAILS = ["-fem_ksp_type", "cg", "-fem_pc_type", "none", "-fem_ksp_max_it", "1"]


def error_lines(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.startswith("error:")]


@pytest.mark.parametrize("n", [1, 2])
def test_failed_solve_ends_every_rank_and_keeps_the_output(n, tmp_path):
    raw = raw_scene("metamaterial_implicit")
    raw["reference"] = "none"
    raw["output"] = {"file": str(tmp_path / "f.h5"), "progress": 0}
    proc = run_cli([write_scene(tmp_path / "f.yaml", raw), *KSP_FAILS], n=n if n > 1 else None,
                   timeout=120)
    assert proc.returncode == 3, proc.stderr
    lines = error_lines(proc.stderr)
    assert len(lines) == 1 and "partition 'fem': linear solve did not converge" in lines[0]
    assert "Traceback" not in proc.stderr
    with h5py.File(tmp_path / "f.h5") as f:
        assert f.attrs["status"] == "failed"
        assert "DIVERGED_MAX_IT" in f.attrs["message"]
        done = int(f.attrs["n_system_steps"])
        assert f["probes/p550/t"].shape == (done + 1,)


def test_interrupt_on_two_ranks_ends_both_and_keeps_the_histories(tmp_path):
    raw = raw_scene("six_dof")
    raw["time"]["end"] = 4000.0                         # minutes of stepping: interrupted long before
    raw["reference"] = "none"
    raw["output"] = {"file": str(tmp_path / "i.h5"), "progress": 0.3}
    cmd = [mpiexec(), "-n", "2", sys.executable, "-m", "solver", str(write_scene(tmp_path / "i.yaml", raw))]
    proc = subprocess.Popen(cmd, cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)},
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        for line in proc.stdout:                        # stepping has started
            if line.startswith("[solver] t ="):
                break
        proc.send_signal(signal.SIGINT)                 # what Ctrl-C does to mpiexec
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err
    lines = error_lines(err)
    assert len(lines) == 1 and "interrupted (SIGINT)" in lines[0] and "Traceback" not in err
    with h5py.File(tmp_path / "i.h5") as f:
        assert f.attrs["status"] == "failed" and "interrupted" in f.attrs["message"]
        done = int(f.attrs["n_system_steps"])
        assert 0 < done < 8_000_000
        assert f["probes/x3/displacement"].shape == (done + 1,)


@pytest.mark.parametrize("n", [1, 2])
def test_bad_partition_option_is_one_line_on_every_rank_count(n, tmp_path):
    proc = run_cli(["configs/six_dof.yaml", "--set", f"output.file={tmp_path / 'b.h5'}",
                    "-fem_mat_type", "nosuch"], n=n if n > 1 else None, timeout=120)
    assert proc.returncode == 2, proc.stderr
    lines = error_lines(proc.stderr)
    assert len(lines) == 1 and "-fem_" in lines[0] and "nosuch" in lines[0]
    assert not (tmp_path / "b.h5").exists()


def test_missing_options_file_is_one_line(tmp_path):
    proc = run_cli(["configs/six_dof.yaml", "-options_file", str(tmp_path / "nope.opts")])
    assert proc.returncode == 2
    assert proc.stderr.strip() == f"error: -options_file {tmp_path / 'nope.opts'}: file not found"


@pytest.mark.parametrize("value", ["0", "abc", "-1", ""])
def test_run_sh_refuses_a_bad_rank_count(value):
    proc = subprocess.run([str(ROOT / "run.sh"), "-n", value, "configs/six_dof.yaml"],
                          cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 4
    assert proc.stderr.strip() == f"error: -n needs a whole number of ranks >= 1, got '{value}'"
