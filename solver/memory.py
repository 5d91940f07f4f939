"""Freed heap memory given back to the operating system between set-up stages.

glibc keeps what C, C++ and Python code free in its heap: gmsh's mesh after
``gmsh.finalize``, a stage's temporaries below the mmap threshold.  The
process's resident size stays where it was, and the next stage's peak comes on
top of it.  :func:`release` calls glibc's ``malloc_trim(0)``, which returns
every free page of the heap (measured: after meshing the 2.27 M-DOF bar of
benchmarks/bench_memory.py, 398 -> 191 MB resident).  Elsewhere (no glibc) it
does nothing.

:func:`zeros_if_zero` marks an all-zero array (a share's u0 and v0 of a
continuum at rest) to travel as ``np.zeros(shape)``: the receiver's copy is
calloc'd pages that hold no resident memory until written.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import functools

import numpy as np


@functools.cache
def _trim():
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        return libc.malloc_trim
    except (OSError, AttributeError):
        return None


def release() -> None:
    """Return the heap's free pages to the operating system (glibc only)."""
    trim = _trim()
    if trim is not None:
        trim(0)


class _Zeros(np.ndarray):
    """An all-zero array that pickles as ``np.zeros(shape, dtype)``."""

    def __reduce_ex__(self, protocol):
        return np.zeros, (self.shape, self.dtype)


def zeros_if_zero(a):
    """``a``, or where it is all zero a view of it that pickles as np.zeros."""
    if isinstance(a, np.ndarray) and a.size and not a.any():
        return a.view(_Zeros)
    return a
