"""One BLAS thread per MPI rank: the ranks already use the cores.

OpenBLAS, OpenMP and MKL read these variables once, when numpy loads them, so
:func:`one_blas_thread` only helps before numpy is imported.  The entry points
call it first: :func:`solver.tools.cli.main` (``python -m solver``, ``mts-solver``,
``run.sh``) and the functions of :mod:`solver.tools.api`.  A variable the user
set is kept; a script that imported numpy earlier keeps numpy's threads.
Importing :mod:`solver` changes nothing.
"""
import os

VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def one_blas_thread(environ=None) -> None:
    """Set every variable of VARIABLES to 1 where it is not set."""
    environ = os.environ if environ is None else environ
    for name in VARIABLES:
        environ.setdefault(name, "1")
