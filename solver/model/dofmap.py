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
        return cls(np.full(n_nodes, dof, dtype=np.int64))

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
