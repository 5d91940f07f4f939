"""Checkpoints a user's habits cannot lose: a run stopped by SIGTERM (a batch
system's walltime), Ctrl-C, a failure or a guard restarts from its last
checkpoint and ends bitwise equal to the uninterrupted run, on every scheme and
with heat, breakage and contact; a damaged checkpoint is refused with the file
untouched; a typo'd flag or PETSc option is refused before anything is built
or stepped; a fresh run does not replace a file that holds a checkpoint;
temporaries of a killed write are cleaned; SIGTERM during set-up is one line.

Interrupts come from the real signal path: ``MTS_SIGTERM_AT_STEP=k`` makes
rank 0 send itself SIGTERM after system step k (deterministic, no polling),
and one test sends SIGTERM from outside as a batch system does."""
import copy
import hashlib
import os
import signal
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest

from conftest import ROOT, mpiexec, raw_scene, run_cli, write_scene


def configure(raw, tmp_path, name, end=None, every=100, energy_every=10):
    raw = copy.deepcopy(raw)
    raw["name"] = name
    if end is not None:
        raw["time"]["end"] = end
    raw["output"] = {"file": str(tmp_path / f"{name}.h5"), "checkpoint": {"every": every},
                     "progress": 0, "energy_every": energy_every}
    return write_scene(tmp_path / f"{name}.yaml", raw)


def everything(path):
    """Every dataset of an output file but the checkpoint and the wall clocks."""
    out = {}
    with h5py.File(path) as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and not name.startswith("checkpoint"):
                out[name] = obj[()]
        f.visititems(visit)
        out["n_system_steps"] = f.attrs["n_system_steps"]
        out["status"] = f.attrs["status"]
    return out


def system_steps(raw, end) -> int:
    from solver import scene
    return scene.from_dict(dict(copy.deepcopy(raw), time=dict(raw["time"], end=end))).n_system_steps


def interrupted_then_restarted(raw, tmp_path, end, n=None, n_restart=None):
    """One run to ``end``; the same run SIGTERMed between its 9th and 10th of
    10 checkpoints (exit 130, file marked failed), restarted from its file (on
    ``n_restart`` ranks): both files' contents."""
    steps = system_steps(raw, end)
    every = max(1, steps // 10)
    at = 9 * every + max(1, every // 2)
    whole = configure(raw, tmp_path, "whole", end, every)
    proc = run_cli([whole], n=n, timeout=300)
    assert proc.returncode == 0, proc.stderr
    cut = configure(raw, tmp_path, "cut", end, every)
    out = tmp_path / "cut.h5"
    proc = run_cli([cut], n=n, env={"MTS_SIGTERM_AT_STEP": str(at)}, timeout=300)
    assert proc.returncode == 130, proc.stderr
    assert "interrupted (SIGTERM)" in proc.stderr and "Traceback" not in proc.stderr
    with h5py.File(out) as f:
        assert f.attrs["status"] == "failed"
        done, ck = int(f.attrs["n_system_steps"]), int(f["checkpoint"].attrs["step"])
    assert done >= at and ck == every * (at // every) and ck < done, (done, ck)
    proc = run_cli([cut, "--restart", out], n=n_restart or n, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert f"restarted from {out} at system step {ck}" in proc.stdout
    return everything(tmp_path / "whole.h5"), everything(out)


def assert_same(a, b):
    assert a["status"] == b["status"] == "completed"
    assert a["n_system_steps"] == b["n_system_steps"]
    assert set(a) == set(b)
    for key in a:
        x, y = np.asarray(a[key]), np.asarray(b[key])
        same = np.array_equal(x, y, equal_nan=x.dtype.kind == "f")
        assert same, key


def conserving_chain():
    from test_conserving import SPLIT, chain
    raw = chain(4, end=60.0)
    raw["loads"] = [{"node": SPLIT, "kind": "half_sine", "amplitude": 0.5, "duration": 50.0}]
    raw["reference"] = "none"
    return raw


CASES = {
    "overlap": (lambda: raw_scene("six_dof"), 4.0),
    "staggered": (lambda: raw_scene("five_node"), 9.0),
    "gc": (lambda: dict(raw_scene("five_node"), coupling={"scheme": "gc"}), 9.0),
    "conserving": (conserving_chain, 60.0),
    "transition": (lambda: raw_scene("wave_bar_transition"), 1.12e-5),
    "heat": (lambda: dict(raw_scene("laser_disc"), reference="none"), 2.6e-6),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_a_sigtermed_run_restarts_to_the_uninterrupted_run(tmp_path, case):
    make, end = CASES[case]
    raw = make()
    whole, again = interrupted_then_restarted(raw, tmp_path, end)
    assert_same(whole, again)


def test_breakage_and_contact_restart_from_an_interrupt(tmp_path):
    """tests/test_bonds.py's crack: a tension pulse breaks the DEM core's first
    column (contact on).  Interrupted after the breaks, the restarted run has
    the same broken bonds at the same times and the same histories, bitwise."""
    from test_bonds import nonlinear
    raw = nonlinear(model__lattice__break_strain=3e-4, partitions__0__ratio=1,
                    damping__beta=2e-9)
    raw["model"]["lattice"]["contact"] = {"stiffness": 1.68e7}
    raw["reference"] = "none"
    raw["loads"] = [dict(raw["loads"][0], direction=[-1.0, 0.0]),
                    dict(raw["loads"][0], start=2.0e-5, duration=3.0e-5)]
    whole, again = interrupted_then_restarted(raw, tmp_path, 3.64e-5)   # 2600 steps
    t_break = whole["broken_bonds"][:, 0]
    assert len(t_break) >= 37 and t_break.min() < 0.9 * 3.64e-5     # in the checkpoint
    assert_same(whole, again)


def test_two_ranks_interrupted_restart_on_two(tmp_path):
    whole, again = interrupted_then_restarted(raw_scene("six_dof"), tmp_path, 2.0, n=2)
    assert_same(whole, again)


def test_a_run_stopped_by_the_guard_restarts_from_its_checkpoint(tmp_path):
    """An unstable step let through (guard.stable_step false) grows until the
    energy guard stops it; restarting from its last checkpoint reads the file
    and stops at the same system step with the same histories."""
    raw = raw_scene("six_dof")
    raw["guard"] = {"stable_step": False}
    raw["partitions"][0]["ratio"] = 20000              # 2 s, the critical step is 1.06 s
    path = configure(raw, tmp_path, "blow", 400.0, 3, energy_every=1)
    proc = run_cli([path], timeout=120)
    assert proc.returncode == 3, proc.stderr
    first = everything(tmp_path / "blow.h5")
    with h5py.File(tmp_path / "blow.h5") as f:
        ck = int(f["checkpoint"].attrs["step"])
    assert first["status"] == "failed" and ck < first["n_system_steps"]
    proc = run_cli([path, "--restart", tmp_path / "blow.h5"], timeout=120)
    assert proc.returncode == 3, proc.stderr
    assert f"at system step {ck}" in proc.stdout
    second = everything(tmp_path / "blow.h5")
    assert second["n_system_steps"] == first["n_system_steps"]
    for key in first:
        if key.startswith("probes/"):
            assert np.array_equal(first[key], second[key], equal_nan=True), key


def test_sigterm_from_outside_on_two_ranks(tmp_path):
    """The batch system's walltime kill: SIGTERM to mpiexec while stepping ends
    every rank with exit 130 and a failed file; the restart completes it."""
    path = configure(raw_scene("six_dof"), tmp_path, "ext", 8.0, 2000)
    out = tmp_path / "ext.h5"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([mpiexec(), "-n", "2", sys.executable, "-m", "solver", str(path)],
                            cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    deadline = time.time() + 120
    while time.time() < deadline and proc.poll() is None:
        try:
            with h5py.File(out, "r") as f:
                if "checkpoint" in f and f["checkpoint"].attrs["step"] >= 2000:
                    break
        except (OSError, KeyError):
            pass
        time.sleep(0.01)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    with h5py.File(out) as f:
        assert f.attrs["status"] == "failed"
    proc = run_cli([path, "--restart", out], n=2, timeout=300)
    assert proc.returncode == 0, proc.stderr
    with h5py.File(out) as f:
        assert f.attrs["status"] == "completed" and f.attrs["n_system_steps"] == 16000


def sha(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_a_damaged_checkpoint_is_refused_untouched(tmp_path):
    """Bytes flipped inside a checkpoint dataset (Fletcher32) or one of its
    attributes (the checkpoint's digest): exit 2, one line, the file untouched."""
    path = configure(raw_scene("six_dof"), tmp_path, "c", 4.0, 2000)
    out = tmp_path / "c.h5"
    assert run_cli([path]).returncode == 0
    good = out.read_bytes()
    with h5py.File(out) as f:
        ds = f["checkpoint/partitions/fem/uva"]
        offset = ds.id.get_chunk_info(0).byte_offset
    for where, flip in (("dataset", offset + 40), ("attribute", None)):
        data = bytearray(good)
        if flip is not None:
            data[flip] ^= 0xFF
            out.write_bytes(bytes(data))
        else:
            out.write_bytes(good)
            with h5py.File(out, "r+") as f:
                f["checkpoint/partitions/fem"].attrs["steps"] = 7
        before = sha(out)
        proc = run_cli([path, "--restart", out, "--set", "time.end=8.0"])
        assert proc.returncode == 2, (where, proc.stderr)
        line, = proc.stderr.strip().splitlines()
        assert "damaged" in line and str(out) in line, line
        assert sha(out) == before


def test_a_typo_is_refused_before_anything_is_built(tmp_path):
    """--restrt (a typo of --restart) and a misspelled PETSc option leave the
    file holding a checkpoint as it is: refused before stepping, with the
    nearest known word."""
    path = configure(raw_scene("five_node"), tmp_path, "t", 9.0, 1000)
    out = tmp_path / "t.h5"
    assert run_cli([path]).returncode == 0
    good = sha(out)
    cases = [
        ([path, "--restrt", out], "unknown option --restrt (did you mean --restart?)"),
        ([path, "--sett", "time.end=1"], "unknown option --sett (did you mean --set?)"),
        ([path, "--restart", out, "--set", "time.end=12", "-implicit_pc_typ", "lu"],
         "-implicit_pc_typ (did you mean -implicit_pc_type?)"),
        ([path, "--restart", out, "--set", "time.end=12", "-explicit_ksp_type", "cg"],
         "-explicit_ksp_type (partition 'explicit' creates no object")
    ]
    for args, words in cases:
        proc = run_cli(args)
        assert proc.returncode == 2, (args, proc.stderr)
        line, = proc.stderr.strip().splitlines()
        assert words in line, line
        assert sha(out) == good
    proc = run_cli([path, "--help"])
    assert proc.returncode == 0 and "usage:" in proc.stdout and sha(out) == good


def test_a_fresh_run_does_not_replace_a_checkpoint(tmp_path):
    path = configure(raw_scene("five_node"), tmp_path, "f", 9.0, 1000)
    out = tmp_path / "f.h5"
    assert run_cli([path]).returncode == 0
    good = sha(out)
    proc = run_cli([path])
    assert proc.returncode == 2
    line, = proc.stderr.strip().splitlines()
    assert f"{out} holds a checkpoint at system step 3000" in line and "--overwrite" in line
    assert sha(out) == good
    proc = run_cli([path, "--overwrite"])
    assert proc.returncode == 0, proc.stderr


def test_stale_temporaries_are_removed_and_no_directory_is_left(tmp_path):
    path = configure(raw_scene("five_node"), tmp_path, "s", 9.0, 1000)
    dead = subprocess.Popen(["true"])
    dead.wait()
    stale = tmp_path / f".s.h5.tmp-{dead.pid}"
    stale.write_bytes(b"half a file")
    live = tmp_path / f".s.h5.tmp-{os.getpid()}"          # a live writer's: kept
    live.write_bytes(b"being written")
    assert run_cli([path]).returncode == 0
    assert not stale.exists() and live.exists()
    # an unstable step with the output in a new directory leaves no directory
    new = tmp_path / "new" / "deeper" / "u.h5"
    proc = run_cli([path, "--set", f"output.file={new}", "--set", "partitions.implicit.ratio=1",
                    "--set", "time.dt=100"])
    assert proc.returncode == 2, proc.stderr
    assert not (tmp_path / "new").exists()


def catches_sigterm(pid) -> bool:
    try:
        with open(f"/proc/{pid}/status") as f:
            mask = next(int(line.split()[1], 16) for line in f if line.startswith("SigCgt"))
    except (OSError, StopIteration):
        return False
    return bool(mask >> (signal.SIGTERM - 1) & 1)


def descendants(pid) -> list[int]:
    try:
        with open(f"/proc/{pid}/task/{pid}/children") as f:
            kids = [int(k) for k in f.read().split()]
    except OSError:
        return []
    return kids + [d for k in kids for d in descendants(k)]


def is_solver(pid) -> bool:
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            return b"solver" in f.read().split(b"\0")
    except OSError:
        return False


def wait_for_handlers(pid, n):
    """Until the n solver processes (mpiexec's descendants for n > 1) catch
    SIGTERM: the interpreter's own start-up (tens of ms) comes before any
    handler can exist."""
    deadline = time.time() + 60
    while time.time() < deadline:
        pids = [pid] if n == 1 else [p for p in descendants(pid) if is_solver(p)]
        if len(pids) == n and all(catches_sigterm(p) for p in pids):
            return
        time.sleep(0.005)
    raise AssertionError("the solver never installed its SIGTERM handler")


@pytest.mark.parametrize("n", [1, 2])
def test_sigterm_during_set_up_is_one_line(tmp_path, n):
    """SIGTERM while the model is built (before PETSc starts and after, while
    the U-tube's partitions are set up): one line, exit 130, nothing written,
    no PETSc error lines, on 1 and 2 ranks."""
    raw = raw_scene("u_tube")
    path = configure(raw, tmp_path, "setup", None, 1000)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    cmd = [sys.executable, "-m", "solver", str(path)]
    for delay in (0.0, 3.0):         # reading the scene (PETSc not started), set-up
        proc = subprocess.Popen(cmd if n == 1 else [mpiexec(), "-n", str(n), *cmd], cwd=ROOT,
                                env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        wait_for_handlers(proc.pid, n)
        time.sleep(delay)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
        assert proc.returncode == 130, (delay, err)
        line, = err.strip().splitlines()
        assert "interrupted (SIGTERM) before stepping; no output written" in line, line
        assert not (tmp_path / "setup.h5").exists()
