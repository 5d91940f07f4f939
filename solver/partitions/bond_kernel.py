"""The compiled bond-force loop (numba): one pass over the bonds.

For every live bond b = (i, j): d = (X_j - X_i) + (u_j - u_i), L = |d|; a bond stretched
beyond limit_b L0_b breaks (alive_b = False, b written to ``snapped``) and
exerts nothing; otherwise f = k (L - L0) d / L is added to row i and
subtracted from row j (rows >= ``rows`` are ghosts: another piece's).  The
same arithmetic as the numpy path of :class:`solver.partitions.bonds.BondForce`
(tests/test_bonds.py checks the two agree to round-off); the loop replaces its
gather-multiply-bincount passes (benchmarks/bench_lammps.py measures both
against LAMMPS).  The separation is the rest separation dX_b = X_j - X_i
(computed once) plus the difference of the displacements, never x_j - x_i of
the summed positions: x = X + u rounds u to ulp(X), which is ulp(X)/L0 of
a strain (1e-13 for a 0.2 mm bond 0.16 m from the origin), and turns
round-off differences of u (another rank layout sums forces in another
order) into whole ulps of X.  2D and 3D have their own loops so the
components stay in registers.
Bonds come sorted by their first particle (BondForce sorts them once), so a
particle's sum over its run of bonds is written once.
"""
from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True, boundscheck=False)
def _loop2(dX, u, i, j, k, L0, alive, limit, out, rows, snapped, P):
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
        dx, dy = dX[b, 0] + (u[q, 0] - u[p, 0]), dX[b, 1] + (u[q, 1] - u[p, 1])
        L = np.sqrt(dx * dx + dy * dy)
        stretch = L - L0[b]
        if stretch > limit[b] * L0[b]:
            alive[b] = False
            snapped[n_snap] = b
            n_snap += 1
            continue
        pull = k[b] * stretch
        if P is not None:                   # (None: compiled without this line)
            pull += (P[p] + P[q]) / L0[b]
        s = pull / L if L > 0 else 0.0
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
def _loop3(dX, u, i, j, k, L0, alive, limit, out, rows, snapped, P):
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
        dx = dX[b, 0] + (u[q, 0] - u[p, 0])
        dy = dX[b, 1] + (u[q, 1] - u[p, 1])
        dz = dX[b, 2] + (u[q, 2] - u[p, 2])
        L = np.sqrt(dx * dx + dy * dy + dz * dz)
        stretch = L - L0[b]
        if stretch > limit[b] * L0[b]:
            alive[b] = False
            snapped[n_snap] = b
            n_snap += 1
            continue
        pull = k[b] * stretch
        if P is not None:                   # (None: compiled without this line)
            pull += (P[p] + P[q]) / L0[b]
        s = pull / L if L > 0 else 0.0
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


def bond_forces(dX, u, i, j, k, L0, alive, limit, out, rows, snapped, accumulate,
                P=None) -> int:
    """out[rows, dim] (+)= the bond forces at displacements ``u`` (rest
    separations ``dX`` per bond), each bond (p, q) pulling with k (L - L0)
    plus the volumetric term's tension (P_p + P_q) / L0 (``P`` per local
    particle, :mod:`solver.partitions.dilatation`; None: none); returns how
    many bonds broke (their indices in ``snapped``)."""
    if not accumulate:
        out[:] = 0.0
    loop = _loop2 if u.shape[1] == 2 else _loop3
    return loop(dX, u, i, j, k, L0, alive, limit, out, rows, snapped, P)


@numba.njit(cache=True, nogil=True, boundscheck=False)
def dilatation_sums(dX, u, i, j, L0, alive, limit, rows, total, count, snapped, coef, P) -> int:
    """One pass over the bonds for the volumetric term: every live bond's
    strain (L - L0) / L0 added to ``total`` and 1 to ``count`` at its ends
    below ``rows`` (zeroed here); a live bond beyond its critical strain
    counts as broken (not added, its index written to ``snapped``, alive
    left to the caller, which records the break).  Then P = coef (dim /
    count)^2 total of those rows.  Returns how many broke.  Bonds come
    sorted by their first particle: its sums stay in registers over its run."""
    total[:] = 0.0
    count[:] = 0.0
    three = dX.shape[1] == 3
    n_snap, cur = 0, -1
    acc = live = 0.0
    for b in range(i.size):
        p = i[b]
        if p != cur:
            if 0 <= cur < rows:
                total[cur] += acc
                count[cur] += live
            cur, acc, live = p, 0.0, 0.0
        if not alive[b]:
            continue
        q = j[b]
        dx, dy = dX[b, 0] + (u[q, 0] - u[p, 0]), dX[b, 1] + (u[q, 1] - u[p, 1])
        L2 = dx * dx + dy * dy
        if three:
            dz = dX[b, 2] + (u[q, 2] - u[p, 2])
            L2 += dz * dz
        stretch = np.sqrt(L2) - L0[b]
        if stretch > limit[b] * L0[b]:
            snapped[n_snap] = b
            n_snap += 1
            continue
        s = stretch / L0[b]
        acc += s
        live += 1.0
        if q < rows:
            total[q] += s
            count[q] += 1.0
    if 0 <= cur < rows:
        total[cur] += acc
        count[cur] += live
    dim = 3.0 if three else 2.0
    for r in range(rows):
        w = dim / max(count[r], 1.0)
        P[r] = coef[r] * w * w * total[r]
    return n_snap


@numba.njit(cache=True, nogil=True, boundscheck=False)
def rest_length_work(dX, u, i, j, k, L0_old, L0_new, alive, share) -> float:
    """sum over live bonds of share_b 1/2 k ((L - L0_new)^2 - (L - L0_old)^2): the
    change of strain energy when rest lengths change at displacements ``u``
    (rotating particles: its translations)."""
    dim = dX.shape[1]
    total = 0.0
    for b in range(i.size):
        if not alive[b] or share[b] == 0.0:
            continue
        p, q = i[b], j[b]
        L2 = 0.0
        for c in range(dim):
            d = dX[b, c] + (u[q, c] - u[p, c])
            L2 += d * d
        L = np.sqrt(L2)
        total += share[b] * 0.5 * k[b] * ((L - L0_new[b]) ** 2 - (L - L0_old[b]) ** 2)
    return total


@numba.njit(cache=True, nogil=True, boundscheck=False)
def star_rates(g, v, i, j, alive, rows, coef, whole, live, tw, tl, cw, cl):
    """For the damping of the volumetric term's stars
    (:meth:`solver.partitions.dilatation.Volumetric.release_broken`): every
    bond's rate g . (v_j - v_i) (g = d / |d|^2 at rest) summed at its ends
    below ``rows`` over all bonds and over the live ones, then ``whole`` and
    ``live`` = coef (dim / count)^2 sum of those rows (scratch tw, tl, cw, cl)."""
    tw[:] = 0.0
    tl[:] = 0.0
    cw[:] = 0.0
    cl[:] = 0.0
    dim = g.shape[1]
    for b in range(i.size):
        p, q = i[b], j[b]
        rate = 0.0
        for c in range(dim):
            rate += g[b, c] * (v[q, c] - v[p, c])
        for e in (p, q):
            if e < rows:
                tw[e] += rate
                cw[e] += 1.0
                if alive[b]:
                    tl[e] += rate
                    cl[e] += 1.0
    for r in range(rows):
        a = dim / max(cw[r], 1.0)
        whole[r] = coef[r] * a * a * tw[r]
        a = dim / max(cl[r], 1.0)
        live[r] = coef[r] * a * a * tl[r]


@numba.njit(cache=True, nogil=True, boundscheck=False)
def star_release(g, i, j, alive, whole, live, out, rows):
    """out += (K_whole - K_live) v of the stars: per bond (p, q) the difference
    (whole_p + whole_q) - [live] (live_p + live_q) times g on q, minus on p."""
    dim = g.shape[1]
    for b in range(i.size):
        p, q = i[b], j[b]
        delta = whole[p] + whole[q]
        if alive[b]:
            delta -= live[p] + live[q]
        if delta == 0.0:
            continue
        for c in range(dim):
            if q < rows:
                out[q, c] += delta * g[b, c]
            if p < rows:
                out[p, c] -= delta * g[b, c]
