"""The matrix of one system step: how a coupling scheme amplifies a state.

Every scheme here is linear in the state, so one system step is a matrix G
acting on the owned (u, v, a) of all partitions (fixed DOFs left out).
``step_matrix`` builds G column by column through the scheme's own ``step``
(one system step per unit state), so it analyses exactly the code that runs;
its spectral radius is the scheme's amplification per system step (above 1:
unstable).  For small models (a few thousand states): the stability study of
the transition scheme (benchmarks/bench_transition_stability.py,
docs/transition.md) and its tests.
"""
from __future__ import annotations

import numpy as np


def step_matrix(scheme, parts, t0: float = 0.0) -> np.ndarray:
    """G with state_next = G state over the owned (u, v, a) of ``parts`` (one
    rank).  Leaves the partitions' state zero."""
    slots = [(p, f, i) for p in parts for f in range(3) for i in range(p.n_own)
             if not p.fixed_dofs[i]]
    G = np.zeros((len(slots), len(slots)))
    for c, (p, f, i) in enumerate(slots):
        for q in parts:
            q.state[...] = 0.0
        p.state[f, i] = 1.0
        scheme.synchronise()                    # externals as after a system step
        scheme.step(t0)
        G[:, c] = [q.state[g, j] for q, g, j in slots]
    for q in parts:
        q.state[...] = 0.0
    return G


def spectral_radius(G: np.ndarray) -> float:
    return float(np.abs(np.linalg.eigvals(G)).max()) if G.size else 0.0
