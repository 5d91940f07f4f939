"""The node graph as CSR arrays: which nodes share a cell, a bond or a spring.

``Graph(indptr, indices)``: the neighbours of node ``n`` are
``indices[indptr[n]:indptr[n + 1]]``, sorted, without ``n`` itself.  Layouts,
orderings, rank costs and matrix preallocation read it; no per-node Python
objects, so a million-node mesh costs two integer arrays.  A *restricted*
graph keeps every node's row slot but only some rows' entries: what a rank
needs to preallocate its own rows.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from solver.model.dofmap import ranges


class Graph(NamedTuple):
    indptr: np.ndarray
    indices: np.ndarray

    @classmethod
    def from_keys(cls, n_nodes: int, keys: np.ndarray) -> "Graph":
        """From sorted unique edge keys ``a * n_nodes + b`` (both directions)."""
        n = np.int64(n_nodes)
        a, b = keys // n, keys % n
        indptr = np.searchsorted(a, np.arange(n_nodes + 1)).astype(np.int64)
        return cls(indptr, b.astype(np.int64))

    @classmethod
    def from_pairs(cls, n_nodes: int, a: np.ndarray, b: np.ndarray) -> "Graph":
        """From undirected edges (a[i], b[i]); duplicates and self-loops dropped."""
        n = np.int64(n_nodes)
        a, b = np.asarray(a, np.int64), np.asarray(b, np.int64)
        keep = a != b
        keys = np.unique(np.concatenate([a[keep] * n + b[keep], b[keep] * n + a[keep]]))
        return cls.from_keys(n_nodes, keys)

    @property
    def n_nodes(self) -> int:
        return self.indptr.size - 1

    def degree(self, nodes) -> np.ndarray:
        nodes = np.asarray(nodes, dtype=np.int64)
        return self.indptr[nodes + 1] - self.indptr[nodes]

    def row(self, node: int) -> np.ndarray:
        return self.indices[self.indptr[node]:self.indptr[node + 1]]

    def rows(self, nodes) -> np.ndarray:
        """Neighbours of ``nodes``, row after row (with repeats)."""
        nodes = np.asarray(nodes, dtype=np.int64)
        return self.indices[ranges(self.indptr[nodes], self.degree(nodes))]

    def restrict(self, nodes) -> "Graph":
        """The same node numbering with only the rows of ``nodes`` filled."""
        nodes = np.unique(np.asarray(nodes, dtype=np.int64))
        deg = np.zeros(self.n_nodes, dtype=np.int64)
        deg[nodes] = self.degree(nodes)
        indptr = np.concatenate([[0], np.cumsum(deg)]).astype(np.int64)
        return Graph(indptr, self.rows(nodes))

    def induced(self, nodes) -> tuple[np.ndarray, np.ndarray]:
        """(rows, cols) of the edges among ``nodes``, in positions of ``nodes``."""
        nodes = np.asarray(nodes, dtype=np.int64)
        local = np.full(self.n_nodes, -1, dtype=np.int64)
        local[nodes] = np.arange(nodes.size)
        deg = self.degree(nodes)
        r = np.repeat(np.arange(nodes.size), deg)
        c = local[self.rows(nodes)]
        inside = c >= 0
        return r[inside], c[inside]
