"""Stopping a run together: a partition's failure or an interrupt on any rank
ends every rank at the same system step, with the output kept.

A rank never leaves the step loop on its own: a collective exit would leave
the others waiting in the next exchange.  Instead, a partition that fails
(a linear solve that does not converge, a PETSc error, anything raised while
it steps) is marked failed by the scheme, which keeps exchanging; SIGINT and
SIGTERM set a flag.  Before stepping (set-up) :func:`guard_setup`'s handlers
end the run at once with one line and exit 130 (nothing written); the Stopper
takes over before the first output is written and keeps the flag until the
final output is written.  :meth:`Stopper.poll` is the one collective that turns
these local reasons into a common decision: every system step on one rank, and
on several ranks every ``cadence`` system steps, chosen after the first steps
so that a poll comes at least every ~0.2 s of stepping.  A second interrupt
aborts at once (MPI_Abort with exit code 130).
"""
from __future__ import annotations

import os
import signal
import sys
import time

from solver.errors import RunFailed

POLL_SECONDS = 0.2         # stepping time between polls on several ranks
PROBE_STEPS = 8            # system steps polled every step before the cadence is fixed


class Interrupted(RunFailed):
    """SIGINT or SIGTERM during stepping: the output is kept, marked failed."""

    exit_code = 130


_setup = {"mpi": False, "pending": None}


def _interrupt_setup(signum, frame):
    name = signal.Signals(signum).name
    if not _setup["mpi"]:
        # a rank that left before MPI_Init would leave the others waiting in it
        _setup["pending"] = name
        return
    raise KeyboardInterrupt(name)


def mpi_started():
    """MPI is up on every rank: an interrupt that came before it ends the run now."""
    _setup["mpi"] = True
    if _setup["pending"]:
        raise KeyboardInterrupt(_setup["pending"])


def guard_setup():
    """SIGINT and SIGTERM raise KeyboardInterrupt (with the signal's name) in the
    main thread: set-up ends with one line and exit 130 (:mod:`solver.tools.cli`).
    Before :func:`mpi_started` the signal waits for MPI to be up on every rank.
    Installed first thing and again after PETSc's start-up, which installs
    handlers of its own."""
    for sig in (signal.SIGINT, signal.SIGTERM):
        try:
            signal.signal(sig, _interrupt_setup)
        except ValueError:                     # not the main thread
            pass


class Stopper:
    def __init__(self, comm, start: int):
        self.comm = comm
        self.failure = None            # (system step, message) of the first local failure
        self.signal = None
        self.start = start
        self.cadence = 1
        self._t0 = time.perf_counter()
        self._saved = {}
        self.where = "before stepping"         # what the run was doing, for a second interrupt

    # --------------------------------------------------------------- signals
    def __enter__(self):
        for sig in (signal.SIGINT, signal.SIGTERM):
            try:
                self._saved[sig] = signal.signal(sig, self._on_signal)
            except ValueError:         # not the main thread: keep Python's handling
                pass
        return self

    def __exit__(self, *exc):
        for sig, handler in self._saved.items():
            signal.signal(sig, handler)
        return False

    def _on_signal(self, signum, frame):
        if self.signal is not None:            # a second interrupt: stop now
            abort(self.comm, f"interrupted twice: stopped at once ({self.where}; the output "
                             "file keeps what was last written)", 130)
        self.signal = signal.Signals(signum).name

    def signals(self) -> str | None:
        """Collective: the name of a signal any rank received (None if none)."""
        names = self.comm.allgather(self.signal) if self.comm.size > 1 else [self.signal]
        return next((n for n in names if n is not None), None)

    # -------------------------------------------------------------- failures
    def fail(self, k: int, message: str):
        """Partition failure during system step ``k`` (the first one counts)."""
        if self.failure is None:
            self.failure = (k, message)

    def due(self, k: int) -> bool:
        """Whether system step ``k`` polls (the same answer on every rank)."""
        if self.comm.size == 1:
            return self.failure is not None or self.signal is not None
        return (k - self.start) % self.cadence == 0

    def poll(self, k: int):
        """Collective: None to go on, or (steps done, message, interrupted) with
        the steps done being those before the earliest failure."""
        local = (self.failure, self.signal)
        if self.comm.size == 1:
            reports = [local]
        else:
            if k - self.start == PROBE_STEPS:
                per_step = (time.perf_counter() - self._t0) / PROBE_STEPS
                per_step = self.comm.allreduce(per_step, op=_max())
                self.cadence = max(1, int(POLL_SECONDS / max(per_step, 1e-9)))
            reports = self.comm.allgather(local)
        failures = [f for f, _ in reports if f is not None]
        signals = [s for _, s in reports if s is not None]
        if failures:
            step, message = min(failures, key=lambda f: f[0])
            return step - 1, message, False
        if signals:
            return k, f"interrupted ({signals[0]}) at system step {k}", True
        return None


def _max():
    from mpi4py import MPI  # lazy: importing mpi4py starts MPI; the entry point decides when
    return MPI.MAX


def abort(comm, message: str | None, code: int):
    """Print ``message`` (if any) once from this rank and end every rank with ``code``
    (MPI_Abort; MPICH's own abort notice is silenced)."""
    if message:
        try:
            os.write(2, f"error: {message}\n".encode())
        except OSError:
            pass
    if comm is None or comm.size == 1:
        sys.exit(code)
    time.sleep(0.1)                            # let the launcher forward the line
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, 1)
    os.dup2(null, 2)
    comm.Abort(code)
