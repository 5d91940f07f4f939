"""Collective helpers: work done on rank 0 on behalf of all, errors agreed.

``on_root`` runs a step on rank 0 only (reading a file, building the whole
model, planning) and makes its outcome collective: a SolverError it raises is
raised on every rank, and its result is broadcast if asked.  ``agree`` raises
on every rank the first error any rank had.
"""
from __future__ import annotations

from solver.errors import SolverError


def on_root(comm, fn, *args, share: bool = True):
    """``fn(*args)`` on rank 0 of ``comm`` (None: this process alone). A
    SolverError it raises is raised on every rank; with ``share`` every rank
    gets the result, else the other ranks get None."""
    result, error = None, None
    if comm is None or comm.rank == 0:
        try:
            result = fn(*args)
        except SolverError as e:
            error = e
    if comm is not None and comm.size > 1:
        if share:
            result, error = comm.bcast((result, error))
        else:
            error = comm.bcast(error)
    if error is not None:
        raise error
    return result


def agree(comm, error):
    """Collective: raise the first rank's error on every rank if any rank has one."""
    errors = comm.allgather(error) if comm.size > 1 else [error]
    first = next((e for e in errors if e is not None), None)
    if first is not None:
        raise first
