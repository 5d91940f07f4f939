"""The Python API: what the command line does, for scripts.

    import solver
    scene = solver.load("configs/six_dof.yaml", ["partitions.fem.ratio=10"])
    result = solver.run(scene)                      # COMM_WORLD, or comm=...
    u = result.probes["x3"]["displacement"]         # numpy arrays

``load`` reads and validates a scene file with ``--set``-style overrides;
``scene_from_dict`` does the same for a mapping; ``run`` runs a scene on a
communicator (every rank of it calls ``run``) and returns the histories on
every rank; it writes the output file as the command line does.  Errors are
:class:`solver.errors.SolverError` subclasses with one-line messages.
"""
from __future__ import annotations

from solver.threads import one_blas_thread
from solver.model import binding
from solver.petscutil import init
from solver.driver.build import run_flags
from solver.driver.runner import run as _run


def load(path, overrides=()):
    """A validated scene from a YAML file and ``key.path=value`` overrides."""
    one_blas_thread()
    return binding.load(path, list(overrides))


def scene_from_dict(raw: dict):
    """A validated scene from plain data (the YAML's structure)."""
    one_blas_thread()
    return binding.from_dict(raw)


def run(scene, comm=None, petsc_options=(), log=None, restart=None, overwrite=False):
    """Run ``scene`` on ``comm`` (default COMM_WORLD); returns a RunResult with
    ``attrs``, ``partitions``, ``probes`` (name -> t, displacement, velocity
    arrays) and ``energy``.  ``petsc_options`` take effect if PETSc was not
    started yet in this process; ``log``: a print-like callable (default silent);
    ``overwrite``: replace an output file that holds a checkpoint (refused
    otherwise, as on the command line)."""
    one_blas_thread()
    petsc_only, measure_wait = run_flags(petsc_options)
    init(petsc_only)
    return _run(scene, comm, log=log or (lambda *a, **k: None), restart=restart,
                overwrite=overwrite, measure_wait=measure_wait)
