"""The overlap exchange: external copies <- owners' (u, v, a), once per system step.

All owned states live in one global PETSc Vec laid out partition by partition
as [u | v | a] blocks; every rank scatters the entries its partitions hold as
external into one local Vec with a single VecScatter.  On one rank this is a
local gather; on two ranks each partition sends its boundary to the other.
"""
from __future__ import annotations

import numpy as np

from .petscutil import init, vec_on


class Exchange:
    def __init__(self, comm, layouts, parts, dof):
        P = init()
        sizes = [3 * lay.n_owned * dof for lay in layouts]
        offset = np.concatenate([[0], np.cumsum(sizes)])
        local_size = sum(sizes[p.layout.index] for p in parts)
        self.G_arr = np.zeros(local_size)
        self.G = vec_on(self.G_arr, comm, size=(local_size, int(offset[-1])))
        src, dst, blocks = [], [], []
        g_at, x_at = 0, 0
        comp = np.arange(dof)
        for p in parts:
            lay = p.layout
            n_own, n_ext = p.n_own, p.state.shape[1] - p.n_own
            ext, owners = lay.external, lay.external_owner
            # position of every external node in its owner's owned list
            pos = np.empty(ext.size, dtype=np.int64)
            for q in np.unique(owners):
                sel = owners == q
                pos[sel] = np.searchsorted(layouts[q].owned, ext[sel])
            n_q = np.array([layouts[q].n_owned * dof for q in owners], dtype=np.int64)
            e_dof = (np.arange(ext.size)[:, None] * dof + comp).ravel()      # local external DOF
            q_dof = (pos[:, None] * dof + comp).ravel()                     # owner's owned DOF
            base = np.repeat(offset[owners], dof)
            stride = np.repeat(n_q, dof)
            for f in range(3):                                              # u, v, a blocks
                src.append(base + f * stride + q_dof)
                dst.append(x_at + f * n_ext + e_dof)
            blocks.append((p, g_at, n_own, x_at, n_ext))
            g_at += 3 * n_own
            x_at += 3 * n_ext
        src = np.concatenate(src) if src else np.zeros(0, dtype=np.int64)
        dst = np.concatenate(dst) if dst else np.zeros(0, dtype=np.int64)
        self.X_arr = np.zeros(x_at)
        self.X = vec_on(self.X_arr, P.COMM_SELF)
        self.is_from = P.IS().createGeneral(np.asarray(src, dtype=P.IntType), comm=P.COMM_SELF)
        self.is_to = P.IS().createGeneral(np.asarray(dst, dtype=P.IntType), comm=P.COMM_SELF)
        self.scatter = P.Scatter().create(self.G, self.is_from, self.X, self.is_to)
        for obj in (self.G, self.X, self.scatter):
            obj.setOptionsPrefix("exchange_")
        self.values = x_at
        self._copies = []
        for p, g0, n_own, x0, n_ext in blocks:
            g_view = self.G_arr[g0:g0 + 3 * n_own].reshape(3, n_own)
            x_view = self.X_arr[x0:x0 + 3 * n_ext].reshape(3, n_ext)
            self._copies.append((p, p.state[:, :n_own], g_view, x_view, p.state[:, n_own:]))
        self._insert = P.InsertMode.INSERT_VALUES
        self._forward = P.ScatterMode.FORWARD

    def __call__(self):
        for _, owned, g_view, _, _ in self._copies:
            np.copyto(g_view, owned)
        self.scatter.scatter(self.G, self.X, self._insert, self._forward)
        for _, _, _, x_view, external in self._copies:
            np.copyto(external, x_view)

    def destroy(self):
        for obj in (self.scatter, self.is_from, self.is_to, self.G, self.X):
            obj.destroy()
