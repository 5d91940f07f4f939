"""Multi-time-step FEM-DEM structural dynamics with overlapping boundaries.

Pipeline: scene (YAML) -> model (arrays) -> overlap layouts -> partitions
(fem, dem; PETSc) -> system steps with one exchange each -> HDF5 output.
Entry points: ``python -m solver`` (:mod:`solver.cli`), :func:`solver.runner.run`.
"""

import os as _os

# one BLAS thread per MPI rank (ranks already use the cores); set before numpy loads
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    _os.environ.setdefault(_var, "1")

__version__ = "0.2.0"
