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
    the level operators the partition built (``p.level_ops``: ratio -> -K_r,
    :func:`solver.partitions.levels.operators`)."""
    R = p.spec.ratio
    h = p.dt / R
    ratios = [r for r in levels.ratios if r <= R]
    ops = [p.level_ops[r] for r in ratios]
    accs = [p.u.duplicate() for _ in ops]
    u, v, a, minv = p.u, p.v, p.a, p.minv
    U = p.U
    loads = p.loads
    comm = p.comm.tompi4py() if hasattr(p.comm, "tompi4py") else p.comm
    # loads on any rank: every rank makes the Vec (creating PETSc objects is collective)
    loaded = bool(comm.allreduce(int(bool(loads.groups))))
    if loaded:
        ext = p.u.duplicate()
        E = ext.getArray()
        inverse = p.inverse_mass
    vecs = accs + ([ext] if loaded else [])
    half = [0.5 * r * h for r in ratios] + ([0.5 * h] if loaded else [])
    active = []                                   # per fine step: (levels acting, kick)
    for j in range(1, R + 1):
        on = [i for i, r in enumerate(ratios) if j % r == 0]
        if j < R:
            active.append((on, [ratios[i] * h for i in on] + ([h] if loaded else []),
                           [accs[i] for i in on] + ([ext] if loaded else [])))
        else:
            active.append((on, half, vecs))
    mults = [(K.mult, acc, acc.pointwiseMult) for K, acc in zip(ops, accs)]
    last = np.full(U.shape, np.nan)               # u of the stored accelerations
    track = loads.track if loads.owned else None
    v_maxpy, u_axpy = v.maxpy, u.axpy

    def forces(which):
        for i in which:
            mult, acc, scale = mults[i]
            mult(u, acc)
            scale(acc, minv)

    def external(t):
        E[:] = 0.0
        loads.apply(E, t)
        np.multiply(E, inverse, out=E)

    stale = (lambda: not np.array_equal(U, last)) if comm.size == 1 else \
        (lambda: comm.allreduce(int(not np.array_equal(U, last))) > 0)

    def step(t1):
        t0 = t1 - R * h
        if stale():                               # a restart, a new state: the forces afresh
            forces(range(len(ops)))
        if loaded:
            external(t0)
        v_maxpy(half, vecs)
        for j, (on, coefs, kicks) in enumerate(active, start=1):
            u_axpy(h, v)
            forces(on)
            if loaded:
                external(t0 + j * h)
                if track is not None:
                    track(U)
            v_maxpy(coefs, kicks)
        a.set(0.0)
        a.maxpy([1.0] * len(vecs), vecs)
        last[:] = U

    p.level_vecs = accs + ([ext] if loaded else [])
    return step
