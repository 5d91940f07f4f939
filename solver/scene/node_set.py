"""The node ids a bound scene's partition owns, as one read-only int64 array.

Binding resolves every partition's ``nodes`` or ``group`` to node ids, and
every rank receives the bound scene.  Kept as a tuple of Python ints they
took 36 bytes a node on every rank (27 MB for the 2.27 M-DOF bar of
``benchmarks/bench_memory.py``); a :class:`NodeSet` takes 8, pickles as
its array, and reads as one wherever ``np.asarray`` is applied to it.
"""
from __future__ import annotations

import numpy as np


class NodeSet:
    """Node ids in the order given (``ids``: read-only int64)."""

    __slots__ = ("ids",)

    def __init__(self, ids):
        ids = np.array(ids, dtype=np.int64).reshape(-1)
        ids.flags.writeable = False
        self.ids = ids

    def __array__(self, dtype=None, copy=None):
        ids = self.ids if dtype is None else self.ids.astype(dtype, copy=False)
        return ids.copy() if copy else ids

    def __len__(self) -> int:
        return self.ids.size

    def __bool__(self) -> bool:
        return self.ids.size > 0

    def __iter__(self):
        return iter(self.ids.tolist())

    def __getitem__(self, i):
        return self.ids[i]

    def __eq__(self, other) -> bool:
        if isinstance(other, (NodeSet, tuple, list)):
            return np.array_equal(self.ids, np.asarray(other, dtype=np.int64))
        return NotImplemented

    def __hash__(self) -> int:                # as the tuple it equals
        return hash(tuple(self.ids.tolist()))

    def __getstate__(self):
        return (self.ids,)

    def __setstate__(self, state):
        ids, = state
        ids.flags.writeable = False
        self.ids = ids

    def __repr__(self) -> str:
        return f"NodeSet({self.ids.size} nodes)"
