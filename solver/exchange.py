"""The overlap exchange: external copies <- owners' (u, v, a).

All owned states live in one global PETSc Vec laid out partition by partition
as [u | v | a] blocks; every rank scatters the entries its receiving
partitions hold as external into one local Vec with a single VecScatter.  On
one rank this is a local gather; on two ranks each partition sends its
boundary to the other.  The concurrent scheme refreshes every partition's
externals at once; the staggered scheme uses one exchange per direction
(``receivers``).
"""
from __future__ import annotations

import numpy as np

from .petscutil import init, vec_on


class Exchange:
    """Refresh the externals of the ``receivers`` (partition indices; default
    all local partitions) from their owners; every local partition sends."""

    def __init__(self, comm, layouts, parts, dof, receivers=None):
        P = init()
        sizes = [3 * lay.n_owned * dof for lay in layouts]
        offset = np.concatenate([[0], np.cumsum(sizes)])
        local_size = sum(sizes[p.layout.index] for p in parts)
        self.G_arr = np.zeros(local_size)
        self.G = vec_on(self.G_arr, comm, size=(local_size, int(offset[-1])))
        self._send, g_at = [], 0
        for p in parts:
            g_view = self.G_arr[g_at:g_at + 3 * p.n_own].reshape(3, p.n_own)
            self._send.append((p.state[:, :p.n_own], g_view))
            g_at += 3 * p.n_own
        src, dst, blocks, x_at = [], [], [], 0
        comp = np.arange(dof)
        for p in parts:
            if receivers is not None and p.layout.index not in receivers:
                continue
            lay = p.layout
            n_ext = p.state.shape[1] - p.n_own
            ext, owners = lay.external, lay.external_owner
            pos = np.empty(ext.size, dtype=np.int64)      # place in the owner's owned list
            for q in np.unique(owners):
                sel = owners == q
                pos[sel] = np.searchsorted(layouts[q].owned, ext[sel])
            e_dof = (np.arange(ext.size)[:, None] * dof + comp).ravel()      # local external DOF
            q_dof = (pos[:, None] * dof + comp).ravel()                     # owner's owned DOF
            base = np.repeat(offset[owners], dof)
            stride = np.repeat([layouts[q].n_owned * dof for q in owners], dof)
            for f in range(3):                                              # u, v, a blocks
                src.append(base + f * stride + q_dof)
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
        for owned, g_view in self._send:
            np.copyto(g_view, owned)
        self.scatter.scatter(self.G, self.X, self._insert, self._forward)
        for x_view, external in self._receive:
            np.copyto(external, x_view)

    def destroy(self):
        for obj in (self.scatter, self.is_from, self.is_to, self.G, self.X):
            obj.destroy()
