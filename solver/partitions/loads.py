"""The external loads of a partition: its held loaded DOFs grouped by time
function, their application to the residual, the external work of the owned
ones and the memory a checkpoint keeps of them.

The external work is the trapezoidal sum W += 1/2 (f_n + f_n+1) . (u_n+1 - u_n)
over the owned loaded DOFs: the work the trapezoidal rule (Newmark average
acceleration) balances exactly.
"""
from __future__ import annotations

from contextlib import contextmanager

import numpy as np


class LoadGroup:
    """Loaded DOFs sharing one time function g: f = g(t) * scale at ``idx``;
    ``own`` marks the owned ones (their external work is this partition's).
    A single DOF takes a scalar path (no numpy call overhead per step)."""

    def __init__(self, key, at, idx, scale, own):
        self.key = key              # index of the group's first load in the model
        self.at = at
        self.idx = np.asarray(idx, dtype=np.int64)
        self.scale = np.asarray(scale, dtype=float)
        own = np.asarray(own, dtype=bool)
        self.own, self.own_scale = self.idx[own], self.scale[own]
        self.single = self.idx.size == 1
        self.i0, self.s0 = int(self.idx[0]), float(self.scale[0])
        self.val = self.val_prev = 0.0
        self.u_prev = np.zeros(self.own.size)

    def apply(self, R, t):
        """R += f(t); remembers g(t) for the work."""
        v = self.val = self.at(t)
        if self.single:
            R[self.i0] += v * self.s0
        else:
            R[self.idx] += v * self.scale          # DOFs are distinct within a group

    def remember(self, U):
        self.val_prev = self.val
        self.u_prev[:] = U[self.own]

    def work_increment(self, U) -> float:
        """1/2 (f_n + f_n+1) . (u_n+1 - u_n) over the owned DOFs, then remember."""
        if self.single:
            u = float(U[self.i0])
            w = 0.5 * (self.val_prev + self.val) * self.s0 * (u - self.u_prev[0])
            self.u_prev[0] = u
        else:
            u = U[self.own]
            w = 0.5 * (self.val_prev + self.val) * float(np.dot(self.own_scale, u - self.u_prev))
            self.u_prev[:] = u
        self.val_prev = self.val
        return w


GRAVITY_KEY = -1          # gravity's groups are keys -1, -2, -3 (x, y, z): loads count from 0


def _steady(t: float) -> float:
    return 1.0


def gravity(g, mass, layout, starts) -> list[LoadGroup]:
    """The weight m g of every held node: one constant group per axis with g != 0
    (its work, -m g . u over the owned nodes, is external work)."""
    own = np.arange(starts.size) < layout.n_owned
    out = []
    for c, gc in enumerate(g):
        if gc != 0.0:
            idx = starts + c
            out.append(LoadGroup(GRAVITY_KEY - c, _steady, idx, mass[idx] * gc, own))
    return out


class Loads:
    """``groups``: the groups of the held loaded DOFs (applied to the residual);
    ``owned``: those with owned DOFs (their work is ``work``, the partition's
    external work from its loads)."""

    def __init__(self, groups):
        self.groups = list(groups)
        self.owned = [g for g in self.groups if g.own.size]
        self.work = 0.0

    @classmethod
    def of(cls, model, layout, starts, mass=None):
        """Group the held loaded DOFs by time function: one numpy update per group
        and step (a traction on a face is one group), not a Python loop per DOF.
        ``starts``: each held node's first local DOF; ``mass``: the held DOFs'
        lumped masses (the weight m g of a model with gravity)."""
        nodes, comps = model.dofmap.node_of([l.dof for l in model.loads])
        local = layout.local(nodes) if nodes.size else nodes
        groups: dict[int, tuple] = {}
        first: dict[int, int] = {}
        for i, load in enumerate(model.loads):
            first.setdefault(id(load.function), i)
        for load, loc, comp in zip(model.loads, local, comps):
            if loc < 0:
                continue
            _, at, idx, scale, own = groups.setdefault(
                id(load.function), (first[id(load.function)], load.function.at, [], [], []))
            idx.append(int(starts[loc] + comp))
            scale.append(load.scale)
            own.append(loc < layout.n_owned)
        out = [LoadGroup(*g) for g in groups.values()]
        if model.gravity is not None:
            out += gravity(model.gravity, mass, layout, starts)
        return cls(out)

    def apply(self, R, t):
        """R += f(t) of every group."""
        for group in self.groups:
            group.apply(R, t)

    @contextmanager
    def off(self):
        """No load is applied inside (the response to other causes alone); the
        owned groups' work memory is untouched."""
        groups, self.groups = self.groups, []
        try:
            yield
        finally:
            self.groups = groups

    def remember(self, U):
        """The start of the work sum: each owned group's g and displacements now."""
        for group in self.owned:
            group.remember(U)

    def track(self, U):
        """work += the trapezoidal increment of every owned group since the last call."""
        for group in self.owned:
            self.work += group.work_increment(U)

    def memory(self) -> dict:
        """{load key: last load value} of the owned load groups (checkpoint state)."""
        return {g.key: g.val_prev for g in self.owned}

    def restore(self, values: dict, U):
        """Set the groups' load values from ``memory()`` and their displacements from U."""
        for group in self.groups:
            if group.key in values:
                group.val = group.val_prev = values[group.key]
        for group in self.owned:
            group.u_prev[:] = U[group.own]
