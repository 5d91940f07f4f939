"""The state of a partition: its vectors over the held DOFs (owned first, then
the external layers), as numpy arrays and PETSc Vecs that share their memory.

Shapes (n: the partition's held DOFs on this rank):

    state   [3, n]  rows U (displacement), V (velocity), A (acceleration)
    R       [n]     the residual f(t) - K u - C v of the last evaluation
    work    {name: [n]}  the integrator's work arrays (Newmark: ut, vt = u~, v~)
    u, v, a, r, vecs[name]   Vecs on those arrays: integrators use PETSc vector
                    operations, the exchange and the checkpoints copy rows with numpy
"""
from __future__ import annotations

import numpy as np

from solver.petscutil import vec_on


class State:
    def __init__(self, n: int, comm, work=(), prefix: str | None = None):
        self.state = np.zeros((3, n))
        self.U, self.V, self.A = self.state
        self.u, self.v, self.a = (vec_on(x, comm) for x in (self.U, self.V, self.A))
        self.R = np.zeros(n)
        self.r = vec_on(self.R, comm)
        self.work = {name: np.zeros(n) for name in work}
        self.vecs = {name: vec_on(arr, comm) for name, arr in self.work.items()}
        if prefix is not None:
            for vec in self.all_vecs():
                vec.setOptionsPrefix(prefix)

    def all_vecs(self) -> tuple:
        return (self.u, self.v, self.a, self.r, *self.vecs.values())

    def destroy(self):
        for vec in self.all_vecs():
            vec.destroy()
