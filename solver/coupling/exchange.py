"""The overlap exchange: external copies <- owners' (u, v, a).

The owned nodes that some partition holds as external (the *sent* nodes: the
partitions' boundaries, and the layers behind them under the ``layers``
treatment) live in one global PETSc Vec laid out piece by piece (a piece is a
partition's share on one rank, :mod:`solver.partitions.distribute`) as
[u | v | a] blocks; every rank scatters the entries its receiving pieces hold
as external into one local Vec with a single VecScatter, whatever the rank
layout: on one rank a local gather, on several ranks each piece sends its
boundary to the pieces that hold it as external.  Only the sent nodes are
copied, so an exchange costs in proportion to the interfaces, not to the
partitions.  The concurrent scheme
refreshes every partition's externals at once; the staggered scheme uses one
exchange per direction (``receivers``).  Ghosts *within* a partition are not
exchanged here: the partition's parallel matrix refreshes them at every MatMult.
"""
from __future__ import annotations

import numpy as np

from solver.model.dofmap import ranges
from solver.partitions.distribute import piece_on
from solver.petscutil import init, vec_on


class Exchange:
    """Refresh the externals of the ``receivers`` (partition indices; default
    all) from their owners; every piece sends the (u, v, a) of its sent nodes.

    ``dists``: the Distribution of every partition; ``ranks``: the world ranks
    of every partition (:class:`solver.partitions.ranks.Assignment`); ``parts``: this
    rank's pieces in ascending partition order; ``dofmap``: the model's
    :class:`~solver.model.dofmap.DofMap` (DOFs per node may differ)."""

    def __init__(self, comm, dists, ranks, parts, dofmap, receivers=None):
        P = init()
        counts = dofmap.counts
        wanted = [d.external for q, d in enumerate(dists) if receivers is None or q in receivers]
        wanted = np.unique(np.concatenate(wanted)) if wanted else np.zeros(0, np.int64)
        # the global Vec: every rank's pieces in rank order, each [u | v | a] of its sent DOFs
        mine, local_size = [], 0
        for p in ranks.partitions_on(comm.rank):
            own = piece_on(dists, ranks, p, comm.rank).owned
            at_node = np.flatnonzero(np.isin(own, wanted))
            sent = own[at_node]
            n_sent = dofmap.count(sent)
            if n_sent:
                mine.append((p, at_node, sent, local_size, n_sent))
                local_size += 3 * n_sent
        at = comm.exscan(local_size) if comm.size > 1 else 0
        at = at or 0                                      # (exscan gives rank 0 None)
        # every sent node's owner block start, sent DOFs (one field) and first
        # DOF in its sent list: the interfaces only, gathered on every rank
        rows = [(s, np.full(s.size, at + g0), np.full(s.size, n), dofmap.starts(s))
                for _, _, s, g0, n in mine] or [(np.zeros(0, np.int64),) * 4]
        cols = [np.concatenate(c) for c in zip(*rows)]
        if comm.size > 1:
            cols = [np.concatenate(c) for c in zip(*comm.allgather(cols))]
        order = np.argsort(cols[0])
        g_node, g_base, g_stride, g_pos = (c[order] for c in cols)
        mine = [(p, at_node, sent) for p, at_node, sent, _, _ in mine]
        self.G_arr = np.zeros(local_size)
        self.G = vec_on(self.G_arr, comm)           # (PETSc sums the local sizes)
        self._send, g_at = [], 0
        by_index = {p.layout.index: p for p in parts}
        for index, at_node, sent in mine:                  # this rank's pieces, in rank order
            part = by_index[index]
            idx = ranges(part.starts[at_node], counts[sent])  # owned come first in held order
            g_view = self.G_arr[g_at:g_at + 3 * idx.size].reshape(3, idx.size)
            self._send.append((part.state, idx, g_view))
            g_at += 3 * idx.size
        src, dst, blocks, x_at = [], [], [], 0
        for p in parts:
            if receivers is not None and p.layout.index not in receivers:
                continue
            ext = p.layout.external
            n_ext = dofmap.count(ext)
            e_dof = np.arange(n_ext)                                        # local external DOF
            g = np.searchsorted(g_node, ext)                                # its owner's sent entry
            found = g_node[np.minimum(g, g_node.size - 1)] if g_node.size else g_node
            if not np.array_equal(found, ext):
                raise RuntimeError(f"exchange: partition '{p.name}' holds external nodes no "
                                   "piece sends")
            q_dof = ranges(g_base[g] + g_pos[g], counts[ext])
            stride = np.repeat(g_stride[g], counts[ext])
            for f in range(3):                                              # u, v, a blocks
                src.append(q_dof + f * stride)
                dst.append(x_at + f * n_ext + e_dof)
            blocks.append((p, x_at, n_ext))
            x_at += 3 * n_ext
        self.X_arr = np.zeros(x_at)
        self.X = vec_on(self.X_arr, P.COMM_SELF)
        as_is = lambda idx: P.IS().createGeneral(  # noqa: E731
            np.concatenate(idx).astype(P.IntType) if idx else np.zeros(0, P.IntType), comm=P.COMM_SELF)
        self.is_from, self.is_to = as_is(src), as_is(dst)
        self.scatter = P.Scatter().create(self.G, self.is_from, self.X, self.is_to)
        for obj in (self.G, self.X, self.scatter):
            obj.setOptionsPrefix("exchange_")
        self.values = x_at
        self._receive = [(self.X_arr[x0:x0 + 3 * n].reshape(3, n), p.state[:, p.n_own:])
                         for p, x0, n in blocks]
        self._insert = P.InsertMode.INSERT_VALUES
        self._forward = P.ScatterMode.FORWARD

    def __call__(self):
        for state, idx, g_view in self._send:
            np.take(state, idx, axis=1, out=g_view)
        self.scatter.scatter(self.G, self.X, self._insert, self._forward)
        for x_view, external in self._receive:
            np.copyto(external, x_view)

    def destroy(self):
        for obj in (self.scatter, self.is_from, self.is_to, self.G, self.X):
            obj.destroy()
