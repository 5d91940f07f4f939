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

Cost per system step: for each level R / r MatMults with its operator,
scaled by r h M^-1 so that the product is the level's velocity kick (its
empty rows cost next to nothing: PETSc skips them), R drifts u += h v and
R kicks v += sum of the acting levels' kicks (VecMAXPY), all contiguous.
"""
from __future__ import annotations

import numpy as np


def bind(p, levels):
    """``step(t1)`` for partition ``p``: one system step of the levels, with
    the level operators the partition built (``p.level_ops``: ratio ->
    r dt M^-1 (-K_r), :func:`solver.partitions.levels.operators`)."""
    R = p.spec.ratio
    h = p.dt / R
    ratios = [r for r in levels.ratios if r <= R]
    if any(R % r for r in ratios):
        raise ValueError(f"levels {ratios} do not all divide the system ratio {R}")
    ops = [p.level_ops[r] for r in ratios]
    kicks = [K.createVecLeft() for K in ops]       # r dt M^-1 f_r: a level's whole kick
    u, v, a, U, V = p.u, p.v, p.a, p.U, p.V
    loads = p.loads
    E = np.zeros(U.size)
    ld = np.unique(np.concatenate([g.idx for g in loads.groups])) if loads.groups else \
        np.zeros(0, np.int64)
    ld_minv = p.inverse_mass[ld]
    last = np.full(U.shape, np.nan)                # u of the stored kicks
    track = loads.track if loads.owned else None
    comm = p.comm.tompi4py() if hasattr(p.comm, "tompi4py") else p.comm
    stale = (lambda: not np.array_equal(U, last)) if comm.size == 1 else \
        (lambda: comm.allreduce(int(not np.array_equal(U, last))) > 0)
    mults = [K.mult for K in ops]
    halves = [0.5] * len(kicks)
    # inside the step a level kicks v directly (MatMultAdd: only the rows its
    # elements touch); the last evaluation is kept: the closing and the next
    # step's opening half kicks, and the acceleration
    adds = [K.multAdd for K in ops]
    plan = [[i for i, r in enumerate(ratios) if j % r == 0] for j in range(1, R)]
    to_acc = [1.0 / (r * h) for r in ratios]
    v_maxpy, u_axpy = v.maxpy, u.axpy

    def evaluate(which):
        for i in which:
            mults[i](u, kicks[i])

    def kick_loads(t, w):
        loads.apply(E, t)
        V[ld] += (w * ld_minv) * E[ld]
        E[ld] = 0.0

    def step(t1):
        t0 = t1 - R * h
        if stale():                               # a restart, a new state: the kicks afresh
            evaluate(range(len(ops)))
        v_maxpy(halves, kicks)
        if loads.groups:
            kick_loads(t0, 0.5 * h)
        for j, on in enumerate(plan, start=1):
            u_axpy(h, v)
            for i in on:
                adds[i](u, v, v)                   # v += r h M^-1 f_r(u)
            if loads.groups:
                kick_loads(t0 + j * h, h)
                if track is not None:
                    track(U)
        u_axpy(h, v)                               # j = R: every level acts
        evaluate(range(len(ops)))
        v_maxpy(halves, kicks)
        if loads.groups:
            kick_loads(t1, 0.5 * h)
            if track is not None:
                track(U)
        a.set(0.0)
        a.maxpy(to_acc, kicks)                    # a = sum_r M^-1 f_r at t1
        if loads.groups:
            loads.apply(E, t1)
            p.A[ld] += ld_minv * E[ld]
            E[ld] = 0.0
        last[:] = U

    p.level_vecs = kicks
    return step
