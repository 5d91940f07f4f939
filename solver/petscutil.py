"""Thin helpers over petsc4py: start-up, Vecs on numpy memory, matrices from COO.

petsc4py must be initialised with the command line's PETSc options before
``PETSc`` is imported anywhere; :func:`init` does that once, at the entry
point.  Everything else imports ``PETSc`` from here.
"""
from __future__ import annotations

import sys

import numpy as np

_started = False


def init(argv=None):
    """Initialise petsc4py with ``argv`` (PETSc options, e.g. -options_file)."""
    global _started
    if not _started:
        import petsc4py
        petsc4py.init([sys.argv[0]] + list(argv or []))
        _started = True
    from petsc4py import PETSc
    return PETSc


# consumed at PetscFinalize or by the options machinery itself
_LATE = ("log_view", "options_left", "options_view", "options_file", "memory_view", "malloc",
         "help", "checkstack")


def unused_options() -> list[str]:
    """PETSc options given (command line or options file) that nothing used,
    e.g. a misspelled ``-fem_mat_tpye`` or a prefix that names no partition."""
    opts = init().Options()
    return sorted(f"-{name}" for name in opts.getAll()
                  if not name.startswith(_LATE) and not opts.used(name))


def vec_on(array: np.ndarray, comm, size=None):
    """A PETSc Vec sharing the memory of contiguous float64 ``array``."""
    assert array.flags.c_contiguous and array.dtype == np.float64
    P = init()
    if size is None:
        return P.Vec().createWithArray(array, comm=comm)
    return P.Vec().createWithArray(array, size=size, comm=comm)


def aij(rows, cols, vals, n, comm, prefix: str, scale: float = 1.0, bs: int = 1,
        n_global: int | None = None, first: int = 0):
    """Square AIJ matrix (block size ``bs``) from COO entries, duplicates summed.

    ``n`` local rows starting at global row ``first`` (``n_global`` rows in
    all; default: one rank holds everything).  ``rows`` and ``cols`` are
    global indices of this rank's rows only.  The type comes from the options
    (-<prefix>mat_type): PETSc's COO assembly fills any matrix type, so every
    type holds the same values."""
    P = init()
    rows = np.asarray(rows, dtype=P.IntType)
    cols = np.asarray(cols, dtype=P.IntType)
    N = n if n_global is None else n_global
    A = P.Mat().create(comm=comm)
    A.setSizes(((n, N), (n, N)), bsize=bs)
    A.setType(P.Mat.Type.AIJ)
    A.setOptionsPrefix(prefix)
    A.setFromOptions()
    if A.getType().endswith("sbaij"):
        # symmetric storage keeps the upper triangle; the lower one is the same
        A.setOption(P.Mat.Option.IGNORE_LOWER_TRIANGULAR, True)
    A.setPreallocationCOO(rows, cols)
    A.setValuesCOO(scale * np.asarray(vals, dtype=float), P.InsertMode.INSERT_VALUES)
    A.assemble()
    return A


class Stage:
    """A PETSc logging stage usable as a context manager or with push/pop."""

    def __init__(self, name: str):
        self.stage = init().Log.Stage(name)
        self.push = self.stage.push
        self.pop = self.stage.pop
