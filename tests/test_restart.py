"""Checkpoint and restart: a run killed with SIGKILL and restarted from its last
checkpoint ends bitwise identical to the uninterrupted run (same rank count) and
within 1e-12 on another rank count; the output file is valid at every instant;
bad restart files are refused with one line, exit 2, the file untouched."""
import hashlib
import os
import signal
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest

from conftest import ROOT, mpiexec, raw_scene, run_cli, stop_and_restart, write_scene


def scene(tmp_path, name, every=4000):
    raw = raw_scene("six_dof")
    raw["name"] = name
    raw["output"] = {"file": str(tmp_path / f"{name}.h5"), "checkpoint": {"every": every},
                     "progress": 0}
    return write_scene(tmp_path / f"{name}.yaml", raw)


def histories(path):
    with h5py.File(path) as f:
        assert f.attrs["status"] == "completed"
        return {"u": f["probes/x3/displacement"][()], "v": f["probes/x3/velocity"][()],
                "E": f["energy/total"][()], "W": f["energy/external_work"][()],
                "steps": f.attrs["n_system_steps"], "has_checkpoint": "checkpoint" in f}


def kill_after_checkpoint(cmd, out, at_least):
    """Start ``cmd``, SIGKILL it once ``out`` holds a checkpoint at step >= at_least."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True)
    deadline = time.time() + 120
    step = -1
    while time.time() < deadline and proc.poll() is None:
        try:
            with h5py.File(out, "r") as f:          # must be readable at every instant
                assert f.attrs["status"] in ("running", "completed")
                step = int(f["checkpoint"].attrs["step"]) if "checkpoint" in f else step
        except FileNotFoundError:
            pass
        if step >= at_least:
            os.killpg(proc.pid, signal.SIGKILL)
            break
        time.sleep(0.005)
    proc.wait(timeout=30)
    assert step >= at_least, "the run ended before it could be killed"
    with h5py.File(out, "r") as f:
        assert f.attrs["status"] == "running"
        return int(f["checkpoint"].attrs["step"])


@pytest.mark.parametrize("n_first,n_restart", [(1, 1), (2, 2), (1, 2)])
def test_killed_run_restarts_to_the_same_histories(tmp_path, n_first, n_restart):
    ref = scene(tmp_path, "whole")
    assert run_cli([ref]).returncode == 0
    whole = histories(tmp_path / "whole.h5")
    assert whole["has_checkpoint"]                 # a completed file keeps its final state
    cut = scene(tmp_path, "cut")
    out = tmp_path / "cut.h5"
    cmd = [sys.executable, "-m", "solver", str(cut)]
    if n_first > 1:
        cmd = [mpiexec(), "-n", str(n_first), *cmd]
    step = kill_after_checkpoint(cmd, out, 4000)
    assert 4000 <= step < 40000 and step % 4000 == 0
    proc = run_cli([cut, "--restart", out], n=n_restart if n_restart > 1 else None)
    assert proc.returncode == 0, proc.stderr
    assert f"restarted from {out} at system step {step}" in proc.stdout
    again = histories(out)
    assert again["steps"] == whole["steps"] == 40000
    for key in ("u", "v", "E", "W"):
        if n_first == n_restart:
            assert np.array_equal(again[key], whole[key]), key          # bitwise
        else:
            scale = np.abs(whole[key]).max()
            assert np.abs(again[key] - whole[key]).max() <= 1e-12 * scale, key


def test_a_completed_run_goes_on_with_a_later_end(tmp_path):
    """Restarting a completed run with a larger time.end continues it: the same
    histories, bitwise, as one run to the later end."""
    ref = scene(tmp_path, "whole")
    fixed = ["--set", "output.energy_every=20"]
    assert run_cli([ref, *fixed]).returncode == 0
    short = scene(tmp_path, "short")
    out = tmp_path / "short.h5"
    assert run_cli([short, *fixed, "--set", "time.end=8.0"]).returncode == 0
    with h5py.File(out) as f:
        assert f.attrs["status"] == "completed" and f["checkpoint"].attrs["step"] == 16000
    proc = run_cli([short, *fixed, "--restart", out])
    assert proc.returncode == 0, proc.stderr
    a, b = histories(tmp_path / "whole.h5"), histories(out)
    for key in ("u", "v", "E", "W"):
        assert np.array_equal(a[key], b[key]), key


def sha(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_bad_restart_files_are_refused(tmp_path):
    cut = scene(tmp_path, "cut")
    out = tmp_path / "cut.h5"
    step = kill_after_checkpoint([sys.executable, "-m", "solver", str(cut)], out, 4000)
    assert step >= 4000
    good = sha(out)
    other = scene(tmp_path, "other")
    cases = [
        ([cut, "--restart", tmp_path / "missing.h5"], "missing.h5: file not found"),
        ([cut, "--restart", cut], "not a readable checkpoint"),
        ([other, "--set", "partitions.fem.ratio=10", "--restart", out],
         "written for scene 'cut' with other model, partitions, steps or loads"),
        ([cut, "--set", "time.end=0.4", "--restart", out], "beyond time.end"),
    ]
    trunc = tmp_path / "trunc.h5"
    trunc.write_bytes(out.read_bytes()[:4096])
    cases.append(([cut, "--restart", trunc], "not a readable checkpoint"))
    other_version = tmp_path / "v0.h5"
    other_version.write_bytes(out.read_bytes())
    with h5py.File(other_version, "r+") as f:
        f["checkpoint"].attrs["format"] = "mts-checkpoint 0"
    cases.append(([cut, "--restart", other_version],
                  "checkpoint format 'mts-checkpoint 0', this version reads 'mts-checkpoint 1'"))
    done = scene(tmp_path, "done")
    assert run_cli([done, "--set", "output.checkpoint=null"]).returncode == 0
    cases.append(([done, "--restart", tmp_path / "done.h5"], "has no checkpoint"))
    for args, words in cases:
        proc = run_cli(args)
        assert proc.returncode == 2, (args, proc.stderr)
        assert words in proc.stderr and "Traceback" not in proc.stderr, (args, proc.stderr)
        assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr
        assert sha(out) == good                      # the restart file is untouched


@pytest.mark.parametrize("motion", ["predictor", "linear"])
def test_transition_run_goes_on_with_a_later_end(tmp_path, motion):
    """The transition scheme (Zhang et al. 2009) continued from its final checkpoint
    equals one run to the later end, bitwise: probe displacement and stress in
    FE and DEM, and the energy.  (With band_motion linear the DEM's band
    state is re-derived on restart as after every exchange.)"""
    raw = raw_scene("wave_bar_transition")
    raw["coupling"]["band_motion"] = motion
    out = {}
    for name, path in zip(("whole", "short"), stop_and_restart(
            raw, tmp_path, 4.48e-5, 2.24e-5, 400)):                # 800 and 400 system steps
        with h5py.File(path) as f:
            out[name] = [f[f"probes/{p}/{k}"][()] for p in "ABC" for k in ("displacement", "stress")]
            out[name].append(f["energy/total"][()])
    for a, b in zip(out["whole"], out["short"]):
        assert np.array_equal(a, b)


def test_the_fingerprint_leaves_out_the_ranks_given():
    """partitions[].ranks does not enter the restart fingerprint (a restart on
    another rank count may give other ranks), while the hash older versions
    wrote with the ranks given is still told apart and accepted."""
    from solver.driver.state import fingerprint
    from solver.model import binding
    plain = binding.load("configs/six_dof.yaml")
    ranks = binding.load("configs/six_dof.yaml", ["partitions.fem.ranks=1",
                                                  "partitions.dem.ranks=1"])
    other = binding.load("configs/six_dof.yaml", ["partitions.fem.ratio=2"])
    assert fingerprint(plain) == fingerprint(ranks) == fingerprint(plain, True)
    assert fingerprint(ranks, True) != fingerprint(ranks)
    assert fingerprint(other) != fingerprint(plain)


def test_keys_added_later_leave_older_fingerprints_alone():
    """gravity, initial.motion, analysis, preload and model.integration (added
    2026-12-03) enter the fingerprint only when set: configs/wave_bar_fem.yaml
    hashes as the version before them did (its checkpoints still restart), and
    setting one changes it."""
    from solver.driver.state import fingerprint
    from solver.model import binding
    plain = binding.load("configs/wave_bar_fem.yaml")
    assert fingerprint(plain) == BEFORE["wave_bar_fem"]   # commit 38515b2, from the checkout root
    for change in (["gravity=[0, -9.81]"], ["initial.motion=[{velocity: [1, 0]}]"],
                   ["model.integration=selective"], ["preload=static"]):
        assert fingerprint(binding.load("configs/wave_bar_fem.yaml", change)) != fingerprint(plain)


BEFORE = {"wave_bar_fem": "7e1c594b8eccc78b47956e765ab7408c"}
