"""The prescribed motions of a partition (scene key ``model.prescribed``,
:mod:`solver.model.prescribed`): its held prescribed DOFs, their state set
before every force evaluation, and the work of the reaction that drives them.

Before the residual is evaluated at time t, the prescribed rows of the
vectors it is given (u, v or the predictors u~, v~) take the exact g(t),
g'(t).  Those DOFs are held (zero inverse mass, identity rows of an implicit
matrix), so their acceleration stays 0 and the corrector u = u~ + beta h^2 a,
v = v~ + gamma h a (or Verlet's closing half kick) leaves them on the
prescribed path: every integrator ends each step exactly on it.

The reaction a support applies, F = m a - r (r = f - K u - C v on the
prescribed rows at the step's final state: a Newmark step evaluates r at its
predictor, r + (beta h^2 + gamma h beta_R)(-K a') is the final one, one
MatMult; central difference undamped needs none), does the work W = sum 1/2 (r_n + r_n+1) . -(u_n+1 - u_n)
+ 1/2 m (v_n+1^2 - v_n^2) over the owned prescribed DOFs (trapezoidal in the
elastic part, exact in the inertial part); it is external work, so the energy
balance closes.  A checkpoint keeps the last r of each owned DOF (load memory
keys below ``MOTION_KEY``).
"""
from __future__ import annotations

import numpy as np

MOTION_KEY = -16          # load-memory key of a prescribed DOF: MOTION_KEY - model DOF index


class Motions:
    """``motions``: the model's :class:`~solver.model.prescribed.Motion` list;
    ``held_dofs``: the model index of each held row; ``n_own`` owned rows
    first; ``vectors``: the partition's :class:`~solver.partitions.state.State`."""

    def __init__(self, motions, held_dofs, n_own: int, mass, vectors):
        order = np.argsort(held_dofs, kind="stable")
        self.groups = []                       # (the motion's at(t), its held rows)
        for m in motions:
            pos = np.searchsorted(held_dofs, m.dofs, sorter=order)
            pos = np.minimum(pos, order.size - 1)
            hit = held_dofs[order[pos]] == m.dofs
            if hit.any():
                self.groups.append((m.at, np.sort(order[pos[hit]])))
        rows = np.concatenate([r for _, r in self.groups]) if self.groups else np.zeros(0, int)
        self.own = rows[rows < n_own]
        self.keys = MOTION_KEY - held_dofs[self.own]
        self.m = mass[self.own]
        self.r_prev = np.zeros(self.own.size)
        self.r_now = np.zeros(self.own.size)     # r of the last residual (an implicit
                                                 # solve zeroes the held rows of R after it)
        self.u_prev = np.zeros(self.own.size)
        self.v_prev = np.zeros(self.own.size)
        self.R = vectors.R
        # the numpy rows behind each Vec a residual may be given
        arrays = [(vectors.u, vectors.U), (vectors.v, vectors.V)]
        arrays += [(vectors.vecs[k], vectors.work[k]) for k in vectors.work]
        self._arrays = {vec.handle: arr for vec, arr in arrays}

    def __bool__(self) -> bool:
        return bool(self.groups)

    def impose(self, u, v, t: float):
        """Set the prescribed rows of Vecs ``u`` and ``v`` (v may be None) to time t."""
        U = self._arrays[u.handle]
        V = self._arrays[v.handle] if v is not None else None
        for at, rows in self.groups:
            x, xdot = at(t)
            U[rows] = x
            if V is not None:
                V[rows] = xdot

    def capture(self):
        """Keep the prescribed rows of the residual just evaluated."""
        self.r_now[:] = self.R[self.own]

    def remember(self, U, V):
        """The start of the work sum: the residual last captured, u and v now."""
        self.r_prev[:] = self.r_now
        self.u_prev[:] = U[self.own]
        self.v_prev[:] = V[self.own]

    def track(self, U, V, shift: float = 0.0, ka=None) -> float:
        """The reaction's work since the last call (then remember); ``shift``,
        ``ka`` (-K a' on the owned prescribed rows, in their order): the residual
        evaluated before the corrector is moved to the step's final state,
        r + shift (-K a')."""
        r, u, v = self.r_now, U[self.own], V[self.own]
        if shift:
            r = r + shift * ka
        w = -0.5 * float(np.dot(self.r_prev + r, u - self.u_prev)) + \
            0.5 * float(np.dot(self.m, v * v - self.v_prev * self.v_prev))
        self.r_prev[:], self.u_prev[:], self.v_prev[:] = r, u, v
        return w

    def memory(self) -> dict:
        return dict(zip(self.keys.tolist(), self.r_prev.tolist()))

    def restore(self, values: dict, U, V):
        self.r_prev[:] = [values.get(int(k), 0.0) for k in self.keys]
        self.u_prev[:] = U[self.own]
        self.v_prev[:] = V[self.own]
