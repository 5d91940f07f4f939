"""Where a result came from: the effective scene, the PETSc options, the
package versions and the project's commit, stored with every output file."""
from __future__ import annotations

import json
import subprocess
import sys
from functools import lru_cache
from importlib import metadata
from pathlib import Path

from solver.version import __version__


@lru_cache(maxsize=1)
def versions() -> str:
    """JSON {package: version} of what computed the run."""
    out = {"python": sys.version.split()[0]}
    for name in ("numpy", "scipy", "h5py", "meshio", "gmsh", "PyYAML", "mpi4py", "petsc4py"):
        try:                                    # from the installed metadata: nothing imported
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    try:
        from petsc4py import PETSc      # lazy: the run's PETSc, initialised by the entry point
        out["PETSc"] = ".".join(map(str, PETSc.Sys.getVersion()))
        from mpi4py import MPI          # lazy: importing mpi4py starts MPI
        out["MPI"] = MPI.Get_library_version().splitlines()[0].strip()
    except Exception:                           # noqa: BLE001
        pass
    out["solver"] = __version__
    return json.dumps(out, sort_keys=True)


@lru_cache(maxsize=1)
def commit() -> str:
    """``git describe --always --dirty`` of the project, or 'unknown' outside a checkout."""
    root = Path(__file__).resolve().parents[2]
    try:
        proc = subprocess.run(["git", "-C", str(root), "describe", "--always", "--dirty",
                               "--abbrev=12"], capture_output=True, text=True, timeout=10)
        return proc.stdout.strip() or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def attrs(effective_yaml: str, petsc_options) -> dict:
    return {"scene_effective_yaml": effective_yaml, "petsc_options": " ".join(petsc_options),
            "versions": versions(), "commit": commit()}
