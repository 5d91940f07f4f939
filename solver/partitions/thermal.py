"""Thermal forces of a partition's elements (``heat.expansion``).

A linear element at the uniform temperature change dT_e (the mean of its
nodes') wants the free expansion u = alpha dT_e (X - X_c): every strain
component alpha dT_e, no rotation.  Its thermal force is the elastic force of
that field, f_e = alpha dT_e K_e (X_e - X_c), which for a cell is the
integral of B^T D eps_th and for a bond k g g^T is k alpha dT L0 along the bond
(the bond's rest length grown); nodes with rotations (beam models: every
node has three DOFs) do not turn in it.  So a body expanding freely (u = alpha dT X)
carries no stress, and a fixed one the exact thermal stress.  The forces are
linear in the nodal temperatures: one sparse matrix G [held DOFs x model
nodes] assembled once with PETSc's COO insertion, then f_th = alpha G dT (one
MatMult per temperature update).  Lattice bonds from the current
configuration take their temperature through their rest lengths instead
(:mod:`solver.partitions.bonds`).
"""
from __future__ import annotations

import numpy as np

from solver.petscutil import init, vec_on

CHUNK = 4096


class ThermalForce:
    def __init__(self, part, blocks, points, n_model, spec):
        P = init()
        self.part, self.spec = part, spec
        lay, dim = part.layout, part.dof
        rows, cols, vals = [], [], []
        for conn, stiff in blocks:
            for s in range(0, len(conn), CHUNK):
                c = conn[s:s + CHUNK]
                Ke = stiff[np.arange(s, s + len(c))]
                X = points[c]
                X = X - X.mean(axis=1, keepdims=True)
                if dim > X.shape[2]:                  # rotations: none in a free expansion
                    X = np.concatenate([X, np.zeros(X.shape[:2] + (dim - X.shape[2],))], axis=2)
                a = np.einsum("eij,ej->ei", Ke, X.reshape(len(c), -1)) / c.shape[1]
                loc = lay.local(c.ravel()).reshape(c.shape)           # -1: not held here
                dof = (part.starts[np.maximum(loc, 0)][:, :, None] + np.arange(dim)).reshape(len(c), -1)
                held = np.repeat(loc >= 0, dim, axis=1)
                e, i = np.nonzero(held)
                k = c.shape[1]
                rows.append(np.repeat(dof[e, i], k))
                cols.append(c[e].ravel())
                vals.append(np.repeat(a[e, i], k))
        n = part.held_dofs.size
        G = P.Mat().createAIJ(size=(n, n_model), comm=P.COMM_SELF)
        r = np.concatenate(rows).astype(P.IntType) if rows else np.zeros(0, P.IntType)
        cc = np.concatenate(cols).astype(P.IntType) if cols else np.zeros(0, P.IntType)
        G.setPreallocationCOO(r, cc)
        G.setValuesCOO(np.concatenate(vals) if vals else np.zeros(0))
        G.assemble()
        self.G = G
        self.dT = np.zeros(n_model)
        self._dT = vec_on(self.dT, P.COMM_SELF)
        self.force = np.zeros(n)
        self._f = vec_on(self.force, P.COMM_SELF)
        self._u_last = part.U[:part.n_own].copy()

    def set_temperature(self, T_node):
        """f_th = alpha G (T - T0) for the nodes' temperatures ``T_node``."""
        np.subtract(T_node, self.spec.initial, out=self.dT)
        self.G.mult(self._dT, self._f)
        self.force *= self.spec.expansion

    def track(self, count=True) -> float:
        """The work of f_th over the owned DOFs' motion since the last call (0
        unless ``count``: the first call after a start or restart)."""
        n = self.part.n_own
        u = self.part.U[:n]
        work = float(np.dot(self.force[:n], u - self._u_last)) if count else 0.0
        self._u_last[:] = u
        return work

    def destroy(self):
        for obj in (self.G, self._dT, self._f):
            obj.destroy()
