"""The solver's command line as benchmarks run it: ``python -m solver SCENE
--set ...`` (under ``mpiexec -n N`` for N > 1; ``MTS_MPIEXEC`` names another
launcher), one BLAS thread, no progress lines; a failed run stops the
benchmark with its command and the end of its error output."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def solve(scene, sets=(), ranks: int = 1) -> subprocess.CompletedProcess:
    """Run ``scene`` with the ``--set`` items ``sets`` on ``ranks`` ranks."""
    cmd = [sys.executable, "-m", "solver", str(scene),
           *sum((["--set", s] for s in [*sets, "output.progress=0"]), [])]
    if ranks > 1:
        cmd = [os.environ.get("MTS_MPIEXEC", "mpiexec"), "-n", str(ranks), *cmd]
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OPENBLAS_NUM_THREADS": "1"}
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if proc.returncode:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{proc.stderr[-3000:]}")
    return proc
