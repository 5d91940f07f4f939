"""The levelled integrator (``integrator: levels``, made by ``partitions: auto``).

One partition holds every element; the elements of ratio r (a *level*,
:mod:`solver.partitions.levels`) act every r fine steps h, the system step
being R h, R the largest ratio.  Velocity Verlet split by element levels,
the impulse multiple-time-step method (Verlet-I / r-RESPA, Grubmueller et
al. 1991, Tuckerman et al. 1992; on element groups with synchronised steps,
the asynchronous variational integrators of Lew et al. 2003):

    t_0:      v += sum_r (r h / 2) a_r(u_0)                (a_r = M^-1 f_r, f_r = -K_r u)
    j = 1..R: u += h v
              a_r = M^-1 f_r(u) for the levels with j % r == 0
              v += sum_active (r h) a_r        (j < R)
              v += sum_r (r h / 2) a_r         (j = R: the half kicks that close the step)

External loads kick at every fine step (weight h, halves at the ends).
Every kick and every drift is a symplectic map, so the composition is
symplectic: undamped, the energy oscillates without drift (tested over 10^5
fine steps) and the step map's eigenvalues lie on the unit circle wherever
it is stable.  Each level alone is stable for omega_r r h < 2, omega_r the
highest frequency of M^-1 K_r (full nodal masses); that is checked here, on
the assembled level operators, before stepping.  One level (R = 1) is
velocity Verlet, the same map as central difference.

Cost per system step: for each level R / r MatMults with its own operator
(its elements only), R drifts and R kicks over the partition's DOFs.
"""
from __future__ import annotations

import numpy as np



def bind(p, levels):
    """``step(t1)`` for partition ``p``: one system step of the levels, with
    the level operators the partition built (``p.level_ops``: ratio -> -K_r
    over the rows its elements touch, :func:`solver.partitions.levels.operators`)."""
    R = p.spec.ratio
    h = p.dt / R
    ratios = [r for r in levels.ratios if r <= R]
    ops = [p.level_ops[r] for r in ratios]
    rows = [p.level_rows[r] for r in ratios]
    outs = [K.createVecLeft() for K in ops]
    forces = [o.getArray() for o in outs]          # f_r on the level's rows
    minvs = [p.inverse_mass[rw] for rw in rows]    # M^-1 there (0 on fixed DOFs)
    u, U, V = p.u, p.U, p.V
    loads = p.loads
    E = np.zeros(U.size)
    ld = np.unique(np.concatenate([g.idx for g in loads.groups])) if loads.groups else \
        np.zeros(0, np.int64)
    ld_minv = p.inverse_mass[ld]
    # every DOF drifts at the step of the finest level acting on it: its velocity
    # changes only then (loaded DOFs: every fine step); integer ratios that do
    # not divide each other drift everything at every fine step
    lev = np.full(U.size, R, dtype=np.int64)
    for r, rw in zip(ratios, rows):
        lev[rw] = np.minimum(lev[rw], r)
    lev[ld] = 1
    nested = all(b % a == 0 for a in ratios for b in ratios if b > a)
    if not nested:
        lev[:] = 1
    drifts = [(r, np.flatnonzero(lev == r)) for r in sorted(set(lev.tolist()))]
    last = np.full(U.shape, np.nan)               # u of the stored forces
    track = loads.track if loads.owned else None
    comm = p.comm.tompi4py() if hasattr(p.comm, "tompi4py") else p.comm
    stale = (lambda: not np.array_equal(U, last)) if comm.size == 1 else \
        (lambda: comm.allreduce(int(not np.array_equal(U, last))) > 0)
    mults = [K.mult for K in ops]
    plan = []                                       # per fine step j: (drifts, levels acting)
    for j in range(1, R + 1):
        plan.append(([(r * h, idx) for r, idx in drifts if j % r == 0],
                     [i for i, r in enumerate(ratios) if j % r == 0]))

    def evaluate(which):
        for i in which:
            mults[i](u, outs[i])

    def kick(i, w):
        rw = rows[i]
        V[rw] += (w * minvs[i]) * forces[i]

    def kick_loads(t, w):
        loads.apply(E, t)
        V[ld] += (w * ld_minv) * E[ld]
        E[ld] = 0.0

    def step(t1):
        t0 = t1 - R * h
        if stale():                               # a restart, a new state: the forces afresh
            evaluate(range(len(ops)))
        for i, r in enumerate(ratios):
            kick(i, 0.5 * r * h)
        if loads.groups:
            kick_loads(t0, 0.5 * h)
        for j, (moves, on) in enumerate(plan, start=1):
            for dt_l, idx in moves:
                U[idx] += dt_l * V[idx]
            evaluate(on)
            end = j == R
            for i in on:
                kick(i, (0.5 if end else 1.0) * ratios[i] * h)
            if loads.groups:
                kick_loads(t0 + j * h, (0.5 if end else 1.0) * h)
                if track is not None:
                    track(U)
        A = p.A
        A[:] = 0.0
        for i, rw in enumerate(rows):
            A[rw] += minvs[i] * forces[i]
        if loads.groups:
            loads.apply(E, t1)
            A[ld] += ld_minv * E[ld]
            E[ld] = 0.0
        last[:] = U

    p.level_vecs = outs
    return step
