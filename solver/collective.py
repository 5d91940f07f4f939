"""Collective helpers: work done on rank 0 on behalf of all, errors agreed.

``on_root`` runs a step on rank 0 only (reading a file, building the whole
model, planning) and makes its outcome collective: a SolverError it raises is
raised on every rank, and its result is broadcast if asked.  ``scatter_each``
sends every rank its share of rank 0's plan, one at a time.  ``agree`` raises
on every rank the first error any rank had.  ``exact_sum`` adds arrays whose
every entry is one rank's (zero on the others) with one allreduce: the sum is
exact, the 1-rank values to the last bit.  ``idle`` is a barrier the ranks
done first pass asleep: every set-up collective above waits with it.
"""
from __future__ import annotations

import time

import numpy as np

from solver.errors import SolverError, describe


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
        idle(comm)                              # (the others wait asleep for rank 0)
        if share:
            result, error = comm.bcast((result, error))
        else:
            error = comm.bcast(error)
    if error is not None:
        raise error
    return result


def idle(comm):
    """Collective: a barrier that the ranks waiting for others pass asleep
    (a nonblocking barrier tested every POLL s) instead of in MPI's busy
    poll.  For set-up steps whose ranks finish far apart (rank 0 reading and
    planning alone; one rank's partition built or checked long after the
    others'): a rank spinning in MPI slowed rank 0's model build 2.5x and its
    fem piece 2x on 2 ranks of this 2-core machine."""
    req = comm.Ibarrier()
    while not req.Test():
        time.sleep(POLL)


POLL = 0.002                                # seconds between the tests of idle's barrier


def scatter_each(comm, items):
    """Collective: the r-th of ``items`` (on rank 0: a list, or an iterable that
    makes each item when asked, one per rank) to rank r, one message at a time;
    rank 0 drops each once sent, so it holds one other rank's item at a time
    (``comm.scatter`` pickles them all at once: 1.8 GB of rank 0's peak for
    the 2.27 M-DOF bar's shares on 4 ranks).  The items travel as pickle
    protocol 5 with their arrays out of band (:mod:`mpi4py.util.pkl5`): an
    array is sent from its own memory and received into its final buffer, with
    no pickled copy of it on either rank.  An error while making an item
    (rank 0) reaches the ranks still waiting, and is raised on every rank."""
    from mpi4py.util import pkl5  # lazy: importing mpi4py starts MPI; the entry point decides when

    big = pkl5.Intracomm(comm)
    if comm.rank != 0:
        while not big.iprobe(source=0, tag=SCATTER_TAG):   # asleep while rank 0 makes it
            time.sleep(POLL)
        item = big.recv(source=0, tag=SCATTER_TAG)
        idle(comm)
        error = comm.bcast(None)
        if error is not None:
            raise error
        return item
    items = iter(items)
    r, error, cause = 0, None, None
    try:
        mine = next(items)
        for r in range(1, comm.size):
            item = next(items)
            big.send(item, dest=r, tag=SCATTER_TAG)
            del item
    except Exception as e:                      # noqa: BLE001 -- every rank learns it
        cause = e
        error = e if isinstance(e, SolverError) else \
            SolverError(f"rank 0 could not make rank {r}'s share ({describe(e)})")
        for rest in range(max(r, 1), comm.size):        # the ranks still waiting
            big.send(None, dest=rest, tag=SCATTER_TAG)
    idle(comm)
    comm.bcast(error)
    if error is not None:
        raise error from (cause if cause is not error else None)
    return mine


SCATTER_TAG = 2301                          # scatter_each's messages


def agree(comm, error):
    """Collective: raise the first rank's error on every rank if any rank has
    one (the ranks done first wait asleep: :func:`idle`)."""
    if comm.size > 1:
        idle(comm)
    errors = comm.allgather(error) if comm.size > 1 else [error]
    first = next((e for e in errors if e is not None), None)
    if first is not None:
        raise first


def exact_sum(comm, *arrays, out=None):
    """The arrays summed over ``comm`` with one allreduce for all (every entry
    one rank's and zero on the others: exact); a list of arrays of their shapes.
    ``out``: with one array, the buffer that receives its sum."""
    if comm.size == 1 and out is None:
        return list(arrays)
    from mpi4py import MPI  # lazy: importing mpi4py starts MPI; the entry point decides when
    if len(arrays) == 1 and out is not None:
        comm.Allreduce(np.ascontiguousarray(arrays[0]), out, op=MPI.SUM)
        return [out]
    flat = np.concatenate([np.ravel(a) for a in arrays])
    comm.Allreduce(MPI.IN_PLACE, flat, op=MPI.SUM)
    result, at = [], 0
    for a in arrays:
        result.append(flat[at:at + np.size(a)].reshape(np.shape(a)))
        at += np.size(a)
    return result
