"""Run under ``mpiexec -n N python tests/mpi/mpi_scatter.py`` (tests/test_collective.py
does): solver.collective.scatter_each on N ranks.  Rank 0 prints a JSON list,
a row per rank: what it received, and what it raised when rank 0 failed to make a share."""
import json
import sys
from pathlib import Path

import numpy as np
from mpi4py import MPI

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from solver.collective import scatter_each          # noqa: E402
from solver.errors import SceneError                # noqa: E402

comm = MPI.COMM_WORLD
FAIL_AT = int(sys.argv[1]) if len(sys.argv) > 1 else -1   # the share rank 0 cannot make


def share(r):
    """Rank r's share: a dict of arrays (one of 24 MB: larger than one message
    needs) and a frozen object, as the partitions stage sends."""
    rng = np.random.default_rng(r)
    return {"rank": r, "big": rng.random(3_000_000), "idx": np.arange(r, 10 * r + 10, dtype=np.int32),
            "tuple": (r, "x" * r)}


def shares():
    for r in range(comm.size):
        if r == FAIL_AT:
            raise SceneError(f"share {r} cannot be made")
        yield share(r)


out = {"rank": comm.rank}
try:
    got = scatter_each(comm, shares())
    want = share(comm.rank)
    out["same"] = bool(got["rank"] == want["rank"] and np.array_equal(got["big"], want["big"])
                       and np.array_equal(got["idx"], want["idx"]) and got["tuple"] == want["tuple"]
                       and got["idx"].dtype == want["idx"].dtype)
except SceneError as e:
    out["error"] = str(e)
rows = comm.gather(out)                            # every rank got here: no rank hangs
if comm.rank == 0:
    print(json.dumps(rows), flush=True)
