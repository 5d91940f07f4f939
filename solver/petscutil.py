"""Thin helpers over petsc4py: start-up, Vecs on numpy memory, AIJ from COO.

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


def coo_to_csr(rows, cols, vals, n):
    """Sum duplicates and return CSR arrays (indptr, indices, data) for n rows."""
    rows = np.asarray(rows, dtype=np.int64)
    cols = np.asarray(cols, dtype=np.int64)
    keys = rows * n + cols
    uniq, inv = np.unique(keys, return_inverse=True)
    data = np.bincount(inv, weights=vals, minlength=uniq.size)
    r, c = uniq // n, uniq % n
    indptr = np.searchsorted(r, np.arange(n + 1)).astype(P_int())
    return indptr, c.astype(P_int()), data


def P_int():
    return init().IntType


def aij(rows, cols, vals, n, comm, prefix: str, scale: float = 1.0, bs: int = 1):
    """Sequential-layout AIJ matrix from COO entries (block size ``bs``); options
    prefix applied and setFromOptions called so -<prefix>mat_type etc. take effect."""
    P = init()
    indptr, indices, data = coo_to_csr(rows, cols, scale * np.asarray(vals, dtype=float), n)
    A = P.Mat().create(comm=comm)
    A.setSizes((n, n), bsize=bs)
    A.setType(P.Mat.Type.AIJ)
    A.setOptionsPrefix(prefix)
    A.setFromOptions()
    A.setPreallocationCSR((indptr, indices, data))
    A.assemble()
    return A


class Stage:
    """A PETSc logging stage usable as a context manager or with push/pop."""

    def __init__(self, name: str):
        self.stage = init().Log.Stage(name)
        self.push = self.stage.push
        self.pop = self.stage.pop
