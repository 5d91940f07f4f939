"""Multi-time-step FEM-DEM structural dynamics with overlapping boundaries.

Pipeline: scene (YAML) -> model (arrays) -> overlap layouts -> partitions
(fem, dem; PETSc) -> system steps with one exchange each -> HDF5 output.
Entry points: ``python -m solver`` (:mod:`solver.cli`), :func:`solver.runner.run`.
"""

__version__ = "0.1.0"
