"""A network whose nodes carry different DOF counts, for the DOF map's tests.

The six-DOF chain of Li et al. (2023) with an extra DOF on every odd node: DOF 0 is
the chain (springs and loads as in six_dof.yaml), DOF 1 an independent
oscillator to the ground (stiffness K2, unit mass) released from U2.  DOF 0
must follow the plain chain; DOF 1 the central-difference solution
u_n = U2 cos(n Omega h), cos(Omega h) = 1 - (h^2 K2 / m) / 2, exactly.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from solver.model.arrays import Model
from solver.model.dofmap import DofMap

K2, U2 = 4.0, 1.0e-3


class MixedChain(Model):
    def stiffness_blocks(self, held):
        counts = self.dofmap.counts
        out = []
        for conn, Ke in Model.stiffness_blocks(self, held):
            pattern = counts[conn]
            for key in {tuple(p) for p in pattern.tolist()}:
                sel = (pattern == key).all(axis=1)
                place = np.concatenate([[0], np.cumsum(key)[:-1]])    # each corner's DOF 0
                big = np.zeros((int(sel.sum()), sum(key), sum(key)))
                big[:, place[:, None], place[None, :]] = Ke[sel]
                out.append((conn[sel], big))
        odd = np.asarray(held)[counts[held] == 2]
        osc = np.zeros((odd.size, 2, 2))
        osc[:, 1, 1] = K2
        out.append((odd[:, None], osc))
        return out

    bond_blocks = stiffness_blocks


def mixed(model: Model) -> MixedChain:
    """``model`` (1 DOF per node) with a second DOF on its odd nodes."""
    counts = 1 + (np.arange(model.n_nodes) % 2)
    dm = DofMap(counts)
    u0, v0 = np.zeros(dm.n_dofs), np.zeros(dm.n_dofs)
    u0[dm.offsets[:-1]], v0[dm.offsets[:-1]] = model.u0, model.v0
    u0[dm.offsets[:-1][counts == 2] + 1] = U2
    loads = tuple(dataclasses.replace(l, dof=int(dm.offsets[l.dof])) for l in model.loads)
    fields = {f.name: getattr(model, f.name) for f in dataclasses.fields(model)}
    fields.update(u0=u0, v0=v0, loads=loads, dof_counts=counts)
    return MixedChain(**fields)


def run(scene, model, comm, n_steps):
    """Owned (node, component) -> history over ``n_steps`` system steps, on ``comm``."""
    from solver.coupling.schemes import scheme_class
    scheme = scheme_class(scene.coupling.scheme).build(scene, model, comm, lambda *a: None)
    scheme.initialise(model)
    Dt = scene.system_dt
    dm = model.dofmap
    hist = {}
    for s in range(n_steps + 1):
        if s:
            scheme.step((s - 1) * Dt)
        for p in scheme.parts:
            for node, start in zip(p.layout.owned.tolist(), p.starts[:p.layout.n_owned].tolist()):
                for c in range(int(dm.counts[node])):
                    hist.setdefault((node, c), []).append(p.U[start + c])
    for p in scheme.parts:
        p.destroy()
    for e in scheme.exchanges:
        e.destroy()
    out = {}
    for chunk in comm.allgather(hist):
        out.update({k: np.array(v) for k, v in chunk.items()})
    return out

