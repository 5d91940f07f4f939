"""Thin helpers over petsc4py: start-up, Vecs on numpy memory, matrices from COO.

petsc4py must be initialised with the command line's PETSc options before
``PETSc`` is imported anywhere; :func:`init` does that once, at the entry
point.  Everything else imports ``PETSc`` from here.
"""
from __future__ import annotations

import difflib
import sys

import numpy as np

from solver.errors import SceneError

_started = False


def init(argv=None):
    """Initialise petsc4py with ``argv`` (PETSc options, e.g. -options_file)."""
    global _started
    if not _started:
        import petsc4py  # lazy: petsc4py.init must see the options before PETSc is imported
        petsc4py.init([sys.argv[0]] + list(argv or []))
        _started = True
    from petsc4py import PETSc  # lazy: petsc4py.init must see the options before PETSc is imported
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


# option names of the objects a partition creates, for "did you mean" (the used
# names of this run are candidates too)
KNOWN = ("ksp_type", "ksp_rtol", "ksp_atol", "ksp_divtol", "ksp_max_it", "ksp_monitor",
         "ksp_view", "ksp_converged_reason", "ksp_norm_type", "ksp_initial_guess_nonzero",
         "pc_type", "pc_factor_mat_solver_type", "pc_factor_mat_ordering_type",
         "pc_factor_levels", "pc_factor_shift_type", "pc_gamg_type", "pc_gamg_threshold",
         "pc_gamg_agg_nsmooths", "pc_hypre_type", "pc_mg_levels", "pc_asm_overlap",
         "pc_bjacobi_blocks", "sub_pc_type", "sub_ksp_type", "mat_type", "mat_view",
         "mat_block_size", "vec_type")


def check_unused(comm, prefixes):
    """Refuse (SceneError, on every rank) the PETSc options that no rank has used
    once set-up has created every object: a misspelled name would otherwise
    run with the default and warn only at the end.  Options PETSc reads at
    finalisation (-log_view, ...) are not checked.  Names the nearest known
    option (-fem_pc_typ -> -fem_pc_type)."""
    opts = init().Options()
    names = opts.getAll()
    unused = {n for n in names if not n.startswith(_LATE) and not opts.used(n)}
    used = {n for n in names if opts.used(n)}
    if comm.size > 1:
        unused = set.intersection(*comm.allgather(unused))
        used = set.union(*comm.allgather(used))
    if not unused:
        return
    known = used | {f"{p}_{k}" for p in prefixes for k in KNOWN} | set(_LATE)
    lines = []
    for name in sorted(unused):
        match = difflib.get_close_matches(name, sorted(known), n=1, cutoff=0.75)
        head = name.split("_")[0]
        if "_" in name and not any(name.startswith(f"{p}_") for p in prefixes) and \
                not any(k.startswith(f"{head}_") for k in known):
            lines.append(f"-{name} (no partition is named '{head}')")
        elif match and match[0] == name:
            owner = next(p for p in prefixes if name.startswith(f"{p}_"))
            lines.append(f"-{name} (partition '{owner}' creates no object that reads it, e.g. "
                         "no KSP when it is explicit)")
        else:
            lines.append(f"-{name}" + (f" (did you mean -{match[0]}?)" if match else ""))
    raise SceneError(f"PETSc option{'s' if len(lines) > 1 else ''} {', '.join(lines)} "
                     f"{'are' if len(lines) > 1 else 'is'} not used by any object of this run "
                     f"(partition prefixes: {', '.join(p + '_' for p in prefixes)}); nothing ran")


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
