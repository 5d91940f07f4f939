"""Multi-time-step FEM-DEM structural dynamics with overlapping boundaries.

Stages: scene (YAML, configuration) -> model (arrays, layouts) -> partitions
(fem, dem; PETSc) -> coupling (system steps with one exchange each) -> driver
(the run, HDF5 output) -> tools (command line, API).
Entry points: ``python -m solver`` and the ``mts-solver`` console script
(:mod:`solver.__main__`, :mod:`solver.tools.cli`) and the Python API
(:mod:`solver.tools.api`): ``solver.load``, ``solver.scene_from_dict``, ``solver.run``.
"""

from solver.version import __version__  # noqa: F401


def load(path, overrides=()):
    """See :func:`solver.tools.api.load`."""
    # lazy: import solver stays light: the API loads on first use
    from solver.tools.api import load as _load
    return _load(path, overrides)


def scene_from_dict(raw):
    """See :func:`solver.tools.api.scene_from_dict`."""
    # lazy: import solver stays light: the API loads on first use
    from solver.tools.api import scene_from_dict as _from_dict
    return _from_dict(raw)


def run(scene, comm=None, petsc_options=(), log=None, restart=None, overwrite=False):
    """See :func:`solver.tools.api.run`."""
    # lazy: import solver stays light: the API loads on first use
    from solver.tools.api import run as _run
    return _run(scene, comm, petsc_options, log, restart, overwrite)
