"""The compiled bond-force loop (numba): one pass over the bonds.

For every live bond b = (i, j): d = x_j - x_i, L = |d|; a bond stretched
beyond limit_b L0_b breaks (alive_b = False, b written to ``snapped``) and
exerts nothing; otherwise f = k (L - L0) d / L is added to row i and
subtracted from row j (rows >= ``rows`` are ghosts: another piece's).  The
same arithmetic as the numpy path of :class:`solver.partitions.bonds.BondForce`
(tests/test_bonds.py checks the two agree to round-off); the loop replaces its
gather-multiply-bincount passes (benchmarks/bench_lammps.py measures both
against LAMMPS).  Positions are summed once, x = X + U, then the loop reads
them; 2D and 3D have their own loops so the components stay in registers.
Bonds come sorted by their first particle (BondForce sorts them once), so a
particle's sum over its run of bonds is written once.
"""
from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True, boundscheck=False)
def _loop2(x, i, j, k, L0, alive, limit, out, rows, snapped):
    n_snap, cur = 0, -1
    fx = fy = 0.0
    for b in range(i.size):
        p = i[b]
        if p != cur:                        # bonds sorted by i: row p's sum stays in registers
            if 0 <= cur < rows:
                out[cur, 0] += fx
                out[cur, 1] += fy
            cur, fx, fy = p, 0.0, 0.0
        if not alive[b]:
            continue
        q = j[b]
        dx, dy = x[q, 0] - x[p, 0], x[q, 1] - x[p, 1]
        L = np.sqrt(dx * dx + dy * dy)
        stretch = L - L0[b]
        if stretch > limit[b] * L0[b]:
            alive[b] = False
            snapped[n_snap] = b
            n_snap += 1
            continue
        s = k[b] * stretch / L if L > 0 else 0.0
        fx += s * dx
        fy += s * dy
        if q < rows:
            out[q, 0] -= s * dx
            out[q, 1] -= s * dy
    if 0 <= cur < rows:
        out[cur, 0] += fx
        out[cur, 1] += fy
    return n_snap


@numba.njit(cache=True, nogil=True, boundscheck=False)
def _loop3(x, i, j, k, L0, alive, limit, out, rows, snapped):
    n_snap, cur = 0, -1
    fx = fy = fz = 0.0
    for b in range(i.size):
        p = i[b]
        if p != cur:
            if 0 <= cur < rows:
                out[cur, 0] += fx
                out[cur, 1] += fy
                out[cur, 2] += fz
            cur, fx, fy, fz = p, 0.0, 0.0, 0.0
        if not alive[b]:
            continue
        q = j[b]
        dx, dy, dz = x[q, 0] - x[p, 0], x[q, 1] - x[p, 1], x[q, 2] - x[p, 2]
        L = np.sqrt(dx * dx + dy * dy + dz * dz)
        stretch = L - L0[b]
        if stretch > limit[b] * L0[b]:
            alive[b] = False
            snapped[n_snap] = b
            n_snap += 1
            continue
        s = k[b] * stretch / L if L > 0 else 0.0
        fx += s * dx
        fy += s * dy
        fz += s * dz
        if q < rows:
            out[q, 0] -= s * dx
            out[q, 1] -= s * dy
            out[q, 2] -= s * dz
    if 0 <= cur < rows:
        out[cur, 0] += fx
        out[cur, 1] += fy
        out[cur, 2] += fz
    return n_snap


def bond_forces(x, i, j, k, L0, alive, limit, out, rows, snapped, accumulate) -> int:
    """out[rows, dim] (+)= the bond forces at positions ``x``; returns how many
    bonds broke (their indices in ``snapped``)."""
    if not accumulate:
        out[:] = 0.0
    loop = _loop2 if x.shape[1] == 2 else _loop3
    return loop(x, i, j, k, L0, alive, limit, out, rows, snapped)


@numba.njit(cache=True, nogil=True, boundscheck=False)
def rest_length_work(x, i, j, k, L0_old, L0_new, alive, share) -> float:
    """sum over live bonds of share_b 1/2 k ((L - L0_new)^2 - (L - L0_old)^2): the
    change of strain energy when rest lengths change at positions ``x``."""
    dim = x.shape[1]
    total = 0.0
    for b in range(i.size):
        if not alive[b] or share[b] == 0.0:
            continue
        p, q = i[b], j[b]
        L2 = 0.0
        for c in range(dim):
            d = x[q, c] - x[p, c]
            L2 += d * d
        L = np.sqrt(L2)
        total += share[b] * 0.5 * k[b] * ((L - L0_new[b]) ** 2 - (L - L0_old[b]) ** 2)
    return total
