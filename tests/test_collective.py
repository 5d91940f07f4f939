"""solver.collective.scatter_each on several ranks (tests/mpi/mpi_scatter.py
under mpiexec): every rank gets its own share bitwise, arrays included (pickle
protocol 5, out of band), and a share rank 0 cannot make is an error on every
rank instead of a hang."""
import json
import subprocess
import sys

import pytest

from conftest import ROOT, mpiexec


def scatter(n, fail_at=-1):
    proc = subprocess.run([mpiexec(), "-n", str(n), sys.executable,
                           str(ROOT / "tests" / "mpi" / "mpi_scatter.py"), str(fail_at)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_every_rank_gets_its_share_bitwise():
    rows = scatter(3)
    assert [r["rank"] for r in rows] == [0, 1, 2]
    assert all(r.get("same") is True for r in rows), rows


@pytest.mark.parametrize("fail_at", [0, 2])
def test_a_share_rank_0_cannot_make_is_an_error_on_every_rank(fail_at):
    """Rank 0 fails making its own share (0) or the last one (2, once rank 1's
    was sent): all three ranks raise the same error and none waits forever."""
    rows = scatter(3, fail_at)
    assert [r.get("error") for r in rows] == [f"share {fail_at} cannot be made"] * 3, rows
