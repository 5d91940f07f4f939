"""How many degrees of freedom every node carries, and where they sit.

Nodes need not carry the same number of DOFs (a shell node carries rotations
a solid node does not).  ``DofMap(counts)`` numbers the model's DOFs node by
node: DOF ``c`` of node ``n`` has model index ``offsets[n] + c``.  Every
vector over a list of nodes (a partition piece's ``[owned | external]``, a
matrix's rows in a distributed node numbering) holds each node's DOFs
contiguously in list order; :meth:`starts` gives where each node begins.

When every node has the same count, ``block`` is that count, the model index
is ``n * block + c`` and matrices use block formats (BAIJ); otherwise
``block`` is None and matrices are scalar AIJ.
"""
from __future__ import annotations

import numpy as np


def ranges(starts: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """Concatenated ``arange(s, s + l)`` for every (s, l), vectorised."""
    lengths = np.asarray(lengths, dtype=np.int64)
    total = int(lengths.sum())
    if total == 0:
        return np.zeros(0, dtype=np.int64)
    heads = np.concatenate([[0], np.cumsum(lengths)[:-1]])
    return np.repeat(np.asarray(starts, dtype=np.int64) - heads, lengths) + np.arange(total)


class Strided:
    """``np.arange(size) * step`` read as that array (an index, an index
    array of any shape, -1 for the last; a slice or ``np.asarray`` makes the
    array) without holding it."""

    def __init__(self, size: int, step: int):
        self.size, self.step = size, step

    def __len__(self) -> int:
        return self.size

    def __getitem__(self, key):
        if isinstance(key, slice):
            return np.arange(self.size, dtype=np.int64)[key] * self.step
        i = np.asarray(key, dtype=np.int64)
        return np.where(i < 0, i + self.size, i) * self.step

    def __array__(self, dtype=None, copy=None):
        out = np.arange(self.size, dtype=np.int64) * self.step
        return out if dtype is None else out.astype(dtype)


class DofMap:
    def __init__(self, counts):
        self.counts = np.asarray(counts, dtype=np.int64)
        if self.counts.ndim != 1 or (self.counts < 1).any():
            raise ValueError("every node carries at least one DOF")
        self.offsets = np.concatenate([[0], np.cumsum(self.counts)])
        common = np.unique(self.counts)
        self.block = int(common[0]) if common.size == 1 else None

    @classmethod
    def uniform(cls, n_nodes: int, dof: int) -> "DofMap":
        """Every node carries ``dof`` DOFs: no array over the nodes (``counts``
        a read-only broadcast of ``dof``, ``offsets`` a :class:`Strided`), where
        the two arrays were 12 MB on every rank of the 2.27 M-DOF bar."""
        if dof < 1:
            raise ValueError("every node carries at least one DOF")
        self = cls.__new__(cls)
        self.counts = np.broadcast_to(np.int64(dof), (n_nodes,))
        self.offsets = Strided(n_nodes + 1, int(dof))
        self.block = int(dof)
        return self

    def __reduce__(self):
        if isinstance(self.offsets, Strided):        # (a broadcast pickles as a full array)
            return DofMap.uniform, (self.n_nodes, self.block)
        return DofMap, (self.counts,)

    @property
    def n_nodes(self) -> int:
        return self.counts.size

    @property
    def n_dofs(self) -> int:
        return int(self.offsets[-1])

    @property
    def largest(self) -> int:
        return int(self.counts.max()) if self.counts.size else 1

    def count(self, nodes) -> int:
        """DOFs of ``nodes`` together."""
        return int(self.counts[nodes].sum())

    def starts(self, nodes) -> np.ndarray:
        """Where each of ``nodes`` begins in a vector over ``nodes`` in that order."""
        c = self.counts[nodes]
        return np.concatenate([[0], np.cumsum(c)[:-1]]).astype(np.int64) if c.size else c

    def dofs(self, nodes) -> np.ndarray:
        """Model DOF indices of ``nodes``, node after node."""
        nodes = np.asarray(nodes, dtype=np.int64)
        return ranges(self.offsets[nodes], self.counts[nodes])

    def node_of(self, dof) -> np.ndarray:
        """(node, component) of model DOF indices."""
        dof = np.asarray(dof, dtype=np.int64)
        node = np.searchsorted(self.offsets, dof, side="right") - 1
        return node, dof - self.offsets[node]

    def numbered(self, number: np.ndarray) -> np.ndarray:
        """First DOF of every node in the DOF numbering that follows the node
        numbering ``number`` (node -> index, -1: not numbered); -1 elsewhere."""
        first = np.full(number.size, -1, dtype=np.int64)
        inside = np.flatnonzero(number >= 0)
        order = inside[np.argsort(number[inside], kind="stable")]
        first[order] = self.starts(order)
        return first

    def element_dofs(self, conn: np.ndarray, first: np.ndarray) -> np.ndarray:
        """DOF indices [n_el, nd] of elements ``conn`` [n_el, k] in the numbering
        ``first`` (from :meth:`numbered`); -1 for DOFs of unnumbered nodes.  The
        elements of one block set have the same DOF count at each corner."""
        counts = self.counts[conn]
        if counts.size and (counts != counts[:1]).any():
            raise ValueError("the elements of one block set differ in their nodes' DOF counts")
        per = counts[0] if counts.size else np.ones(conn.shape[1], dtype=np.int64)
        f = first[conn]
        cols = [np.where(f[:, j, None] >= 0, f[:, j, None] + np.arange(per[j]), -1)
                for j in range(conn.shape[1])]
        return np.concatenate(cols, axis=1) if cols else np.zeros((len(conn), 0), np.int64)
