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


def incidence(conns, n_cols: int):
    """The cell-node incidence matrix C [cells, n_cols] (scipy CSR of bools) of
    ``conns`` (one per cell family: an [m, k] array, or a tuple of its k
    columns, e.g. a lattice's bond ends, so that no [m, k] copy is made;
    entries below 0 are left out, a repeated node is kept twice), int32
    indices while they fit, written straight into one array; None when there
    are no cells.  C^T C is the node graph's pattern (:meth:`Graph.from_cells`),
    R^T C that of a matrix's rows
    (:func:`solver.partitions.assembly.block_nonzeros`)."""
    from scipy.sparse import csr_matrix  # lazy: scipy loads only where it is used
    conns = [_columns(c) for c in conns]
    conns = [c for c in conns if c and len(c[0])]
    if not conns:
        return None
    total = sum(len(c[0]) * len(c) for c in conns)
    itype = np.int32 if max(n_cols, total) < 2 ** 31 else np.int64
    widths, col, at = [], np.empty(total, dtype=itype), 0
    for cols in conns:
        m, k = len(cols[0]), len(cols)
        if any((c < 0).any() for c in cols):          # missing nodes: kept ones only
            c = np.stack(cols, axis=1)
            keep = c >= 0
            widths.append(keep.sum(axis=1).astype(itype))
            kept = c[keep]
            col[at:at + kept.size] = kept
            at += kept.size
        else:
            block = col[at:at + m * k].reshape(m, k)
            for j, c in enumerate(cols):
                block[:, j] = c
            widths.append(np.full(m, k, dtype=itype))
            at += m * k
    width = np.concatenate(widths)
    ptr = np.zeros(width.size + 1, dtype=itype)
    np.cumsum(width, out=ptr[1:])
    return csr_matrix((np.ones(at, bool), col[:at], ptr), shape=(width.size, n_cols))


def _columns(conn) -> tuple:
    """A cell family's node columns (views): of an [m, k] array (m x 1 if 1-D)
    or a tuple of k columns as given."""
    if isinstance(conn, tuple):
        return tuple(np.asarray(c) for c in conn)
    conn = np.asarray(conn)
    if not conn.size:
        return ()
    conn = conn.reshape(len(conn), -1)
    return tuple(conn[:, j] for j in range(conn.shape[1]))


CHUNK = 65536                   # rows from_cells drops the diagonal of at a time


class Graph(NamedTuple):
    indptr: np.ndarray
    indices: np.ndarray

    @classmethod
    def from_cells(cls, n_nodes: int, conns) -> "Graph":
        """Nodes that share a cell of any of ``conns`` ([m, k] node arrays or
        tuples of their k columns, one per cell family; a bond or spring is a
        2-node cell; a cell may repeat a node):
        the pattern of C^T C, C the cell-node incidence matrix, less its diagonal.
        One sparse product (a few bytes per nonzero), no edge keys to sort.
        ``indices`` are int32 while the node ids fit (76 MB instead of 151 MB
        for the 2.27 M-DOF bar; what every share's graph rows are made of)."""
        C = incidence(conns, n_nodes)
        if C is None:
            return cls(np.zeros(n_nodes + 1, np.int64), np.zeros(0, np.int64))
        A = (C.T.tocsr() @ C).tocsr()
        del C
        A.sort_indices()
        ptr, col = A.indptr, A.indices
        del A                                     # its values: only the pattern counts
        deg = np.diff(ptr).astype(np.int64)
        # the diagonal dropped in place, CHUNK rows at a time (a row's entries
        # only move forward): no second array as long as the pattern
        at = 0
        for a in range(0, n_nodes, CHUNK):
            b = min(a + CHUNK, n_nodes)
            rows = col[ptr[a]:ptr[b]]
            row = np.repeat(np.arange(b - a), deg[a:b])
            off = rows != row + a
            deg[a:b] -= np.bincount(row[~off], minlength=b - a)
            kept = rows[off]
            col[at:at + kept.size] = kept
            at += kept.size
        indptr = np.zeros(n_nodes + 1, dtype=np.int64)
        np.cumsum(deg, out=indptr[1:])
        return cls(indptr, col[:at])     # int32 where the node ids fit: half the bytes

    @classmethod
    def from_pairs(cls, n_nodes: int, a: np.ndarray, b: np.ndarray) -> "Graph":
        """From undirected edges (a[i], b[i]); duplicates and self-loops dropped."""
        return cls.from_cells(n_nodes, [(np.asarray(a), np.asarray(b))])

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

    def neighbour_sums(self, nodes, values, chunk: int = 65536) -> np.ndarray:
        """Sum of ``values`` [n_nodes] over each of ``nodes``' neighbours, read
        ``chunk`` nodes at a time (no array as long as all their edges)."""
        nodes = np.asarray(nodes, dtype=np.int64)
        out = np.zeros(nodes.size)
        for s in range(0, nodes.size, chunk):
            part = nodes[s:s + chunk]
            out[s:s + chunk] = np.bincount(np.repeat(np.arange(part.size), self.degree(part)),
                                           weights=values[self.rows(part)], minlength=part.size)
        return out

    def reach(self, nodes, chunk: int = CHUNK) -> np.ndarray:
        """``nodes`` and their neighbours, sorted, each once (the rows read
        ``chunk`` nodes at a time)."""
        nodes = np.asarray(nodes, dtype=np.int64)
        seen = np.zeros(self.n_nodes, bool)
        seen[nodes] = True
        for a in range(0, nodes.size, chunk):
            seen[self.rows(nodes[a:a + chunk])] = True
        return np.flatnonzero(seen)

    def restrict(self, nodes) -> "Graph":
        """The same node numbering with only the rows of ``nodes`` filled."""
        nodes = np.unique(np.asarray(nodes, dtype=np.int64))
        deg = np.zeros(self.n_nodes, dtype=np.int64)
        deg[nodes] = self.degree(nodes)
        indptr = np.concatenate([[0], np.cumsum(deg)]).astype(np.int64)
        return Graph(indptr, self.rows(nodes))

    def induced(self, nodes, chunk: int = CHUNK) -> tuple[np.ndarray, np.ndarray]:
        """(indptr, indices) of the subgraph among ``nodes``, in positions of
        ``nodes`` (int32 where they fit); a row's columns are sorted when
        ``nodes`` is.  The rows are read ``chunk`` nodes at a time: no index
        array as long as all their edges (rank 0's planning peak was the RCM
        of the 2.27 M-DOF bar's lattice, 160 MB above the graph)."""
        nodes = np.asarray(nodes, dtype=np.int64)
        itype = np.int32 if nodes.size < 2 ** 31 else np.int64
        local = np.full(self.n_nodes, -1, dtype=itype)
        local[nodes] = np.arange(nodes.size, dtype=itype)
        kept = np.zeros(nodes.size, dtype=np.int64)
        out, at = np.empty(int(self.degree(nodes).sum()), dtype=itype), 0
        for a in range(0, nodes.size, chunk):
            part = nodes[a:a + chunk]
            cols = local[self.rows(part)]
            inside = cols >= 0
            row = np.repeat(np.arange(part.size), self.degree(part))
            kept[a:a + part.size] = np.bincount(row[inside], minlength=part.size)
            out[at:at + int(inside.sum())] = cols[inside]
            at += int(inside.sum())
        indptr = np.zeros(nodes.size + 1, dtype=np.int64)
        np.cumsum(kept, out=indptr[1:])
        return indptr, out[:at]
