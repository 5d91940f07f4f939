"""Shared helpers: scene files, in-process runs, CLI subprocesses, mpiexec."""
from __future__ import annotations

import copy
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ROOT / "configs"

# The suite starts some hundred Python processes that import solver/: let them
# share its compiled bytecode (solver/__pycache__, ignored by git) instead of
# compiling every module again in each, whatever PYTHONDONTWRITEBYTECODE says.
os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
sys.dont_write_bytecode = False


def mpiexec() -> str:
    exe = os.environ.get("MTS_MPIEXEC") or shutil.which("mpiexec.mpich") or shutil.which("mpiexec")
    assert exe, "no mpiexec found (run the tests through ./run.sh test)"
    return exe


def raw_scene(name: str) -> dict:
    """configs/NAME.yaml as data, its paths made absolute (so a copy written
    anywhere finds the same mesh and writes to the same results/)."""
    from solver.scene import yaml_load
    from solver.scene.file import anchor_paths
    return anchor_paths(yaml_load((CONFIGS / f"{name}.yaml").read_text()), CONFIGS)


def write_scene(path: Path, raw: dict) -> Path:
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return path


def run_cli(args, n: int | None = None, cwd=None, env=None, timeout=600):
    """Run ``python -m solver ARGS`` (under mpiexec -n N when n is given)."""
    cmd = [sys.executable, "-m", "solver", *map(str, args)]
    if n:
        cmd = [mpiexec(), "-n", str(n), *cmd]
    full_env = {**os.environ, "PYTHONPATH": str(ROOT), **(env or {})}
    return subprocess.run(cmd, capture_output=True, text=True, cwd=cwd or ROOT, env=full_env,
                          timeout=timeout)


def run_cases(cases, tmp_path: Path, n: int | None = None, timeout=600):
    """Several ``python -m solver`` command lines in one launch (under mpiexec -n N
    when n is given; tests/mpi/cli_cases.py): ``cases`` is a list of argument
    lists, or of (arguments, stdout file) pairs to keep a case's rank-0 output;
    ``timeout`` is per case, as run_cli's.  Returns the process; it ends with
    the first failing case's exit code."""
    import json
    spec = [{"argv": list(map(str, c[0])), "stdout": str(c[1])} if isinstance(c, tuple)
            else {"argv": list(map(str, c)), "stdout": None} for c in cases]
    path = tmp_path / f"cases-{n or 1}.json"
    path.write_text(json.dumps(spec))
    cmd = [sys.executable, str(ROOT / "tests" / "mpi" / "cli_cases.py"), str(path)]
    if n:
        cmd = [mpiexec(), "-n", str(n), *cmd]
    return subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT,
                          env={**os.environ, "PYTHONPATH": str(ROOT)},
                          timeout=timeout * len(spec))


def refused(scene, sets, tmp_path, n: int | None = None) -> str:
    """Run SCENE with ``--set`` items ``sets`` (and an output file in tmp_path):
    it must stop with exit 2 before writing anything; returns its one line."""
    out = tmp_path / "refused.h5"
    args = [scene, "--set", f"output.file={out}"]
    for item in sets:
        args += ["--set", item]
    proc = run_cli(args, n=n)
    assert proc.returncode == 2, proc.stderr
    line, = proc.stderr.strip().splitlines()
    assert not out.exists()
    return line


def run_scene(raw: dict, tmp_path: Path, comm=None):
    """Validate and run raw scene data in this process; returns the RunResult."""
    from mpi4py import MPI

    from solver.model import binding
    from solver.petscutil import init
    from solver.driver.runner import run
    init([])
    raw = copy.deepcopy(raw)
    raw.setdefault("output", {})
    raw["output"] = {**(raw["output"] or {}), "file": str(tmp_path / f"{raw['name']}.h5"),
                     "progress": 0}
    return run(binding.from_dict(raw), comm or MPI.COMM_SELF, log=lambda *a: None)


def stop_and_restart(raw: dict, tmp_path: Path, end: float, stop: float, every: int,
                     energy_every: int = 10, n: int | None = None, before=None, restart=(),
                     whole: Path | None = None):
    """Run ``raw`` through the CLI to ``end`` in one go ("whole") and to ``stop``
    ("short"), both with a checkpoint every ``every`` system steps, then restart
    "short" to ``end`` (on ``n`` ranks, with the command-line arguments
    ``restart``); ``before(path)`` looks at the short run's file before the
    restart.  ``whole``: the output of a run to ``end`` made already (by a
    fixture another test shares), used instead of a new one.  Returns the
    paths of both outputs."""
    for name, t in (("whole", end), ("short", stop))[whole is not None:]:
        run = copy.deepcopy(raw)
        run["name"], run["time"]["end"] = name, t
        run["output"] = {"file": str(tmp_path / f"{name}.h5"), "checkpoint": {"every": every},
                         "progress": 0, "energy_every": energy_every}
        proc = run_cli([write_scene(tmp_path / f"{name}.yaml", run)], timeout=300)
        assert proc.returncode == 0, proc.stderr
    if before is not None:
        before(tmp_path / "short.h5")
    run["time"]["end"] = end
    write_scene(tmp_path / "short.yaml", run)
    proc = run_cli([tmp_path / "short.yaml", "--restart", tmp_path / "short.h5", *restart], n=n,
                   timeout=300)
    assert proc.returncode == 0, proc.stderr
    return whole or tmp_path / "whole.h5", tmp_path / "short.h5"


@pytest.fixture
def six_dof():
    return raw_scene("six_dof")


def built(raw, tmp_path):
    """The Assembly (solver.driver.build) of raw scene data on this process."""
    from mpi4py import MPI

    from solver import scene as scene_mod
    from solver.driver.build import build
    from solver.model import binding
    from solver.petscutil import init
    init([])
    raw = dict(raw, output={"file": str(tmp_path / "b.h5")})
    return build(binding.bind(scene_mod.from_dict(raw)), MPI.COMM_SELF)


def mpi_pytest(path: str, n: int, tmp_path: Path, timeout=300) -> list[dict]:
    """pytest on the test file ``path`` under ``mpiexec -n N``: asserts the
    launch succeeded; returns each rank's counts (tests, failures, errors,
    skipped) from its JUnit report."""
    import xml.etree.ElementTree as ET
    report = tmp_path / "junit-{rank}.xml"
    proc = subprocess.run([mpiexec(), "-n", str(n), sys.executable, "-c",
                           "import sys, pytest; from mpi4py import MPI; sys.exit(pytest.main("
                           f"['-q', '-p', 'no:cacheprovider', '{path}', '--junitxml', "
                           f"'{report}'.format(rank=MPI.COMM_WORLD.rank)]))"],
                          cwd=ROOT, capture_output=True, text=True, timeout=timeout)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    counts = []
    for rank in range(n):
        suite = ET.parse(str(report).format(rank=rank)).getroot().find("testsuite")
        counts.append({k: int(suite.get(k)) for k in ("tests", "failures", "errors", "skipped")})
    return counts
