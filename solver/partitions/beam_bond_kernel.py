"""The compiled loop of the 2D beam bonds (numba): one pass over the bonds.

The law is :mod:`solver.partitions.beam_bond`'s (a co-rotational
Euler-Bernoulli/Timoshenko beam between rotating particles); this loop
evaluates it for every bond b = (i, j) from the rest separation dX_b and
the particles' displacements and rotations q = (u_x, u_y, theta) [n, 3]
(the chord's rotation is the angle from dX_b to the current separation, one
atan2, or atan's series below 0.01 rad), and adds the forces and torques to ``out`` [rows, 3] (rows >=
``rows`` are another piece's particles).  Bonds come sorted by their first
particle, so a particle's sum over its run stays in registers (as in
:mod:`solver.partitions.bond_kernel`).  Called by
:mod:`solver.partitions.beam_force`; tests/test_beam_bond.py checks it
against the numpy law and benchmarks/bench_beam_bond.py measures it.
"""
from __future__ import annotations

import numba
import numpy as np

PI = np.pi


@numba.njit(cache=True, nogil=True, boundscheck=False, inline="always")
def _wrap(a):
    return PI - ((PI - a) % (2.0 * PI))


@numba.njit(cache=True, nogil=True, boundscheck=False)
def _loop(dX, q, i, j, L0, k_n, k_diag, k_off, alive, tension, shear, bend, friction, out,
          rows, snapped, mode):
    n_snap, cur = 0, -1
    fx = fy = m = 0.0
    for b in range(i.size):
        p = i[b]
        if p != cur:
            if 0 <= cur < rows:
                out[cur, 0] += fx
                out[cur, 1] += fy
                out[cur, 2] += m
            cur, fx, fy, m = p, 0.0, 0.0, 0.0
        if not alive[b]:
            continue
        r = j[b]
        dx = dX[b, 0] + (q[r, 0] - q[p, 0])
        dy = dX[b, 1] + (q[r, 1] - q[p, 1])
        L = np.sqrt(dx * dx + dy * dy)
        # the chord's rotation: the angle from the rest separation to d, in
        # (-pi, pi]; below 0.01 rad atan's series to t^7 (its next term is 1e-16
        # of beta: round-off), else one atan2
        cross = dX[b, 0] * dy - dX[b, 1] * dx
        dot = dX[b, 0] * dx + dX[b, 1] * dy
        if dot > 0.0 and abs(cross) < 0.01 * dot:
            t = cross / dot
            t2 = t * t
            beta = t * (1.0 - t2 * (1.0 / 3.0 - t2 * (0.2 - t2 / 7.0)))
        else:
            beta = np.arctan2(cross, dot)
        phi_i = q[p, 2] - beta
        if phi_i > PI or phi_i <= -PI:       # rare: an end turned by more than pi
            phi_i = _wrap(phi_i)
        phi_j = q[r, 2] - beta
        if phi_j > PI or phi_j <= -PI:
            phi_j = _wrap(phi_j)
        M_i = k_diag[b] * phi_i + k_off[b] * phi_j
        M_j = k_off[b] * phi_i + k_diag[b] * phi_j
        N = k_n[b] * (L - L0[b])
        if tension[b] < np.inf:          # breakable (BeamBonds.breakable, failure)
            axial = (L - L0[b]) / L0[b]
            if axial + max(abs(M_i), abs(M_j)) * bend[b] > tension[b]:
                broke = 1
            elif (abs(M_i + M_j) / L / (k_n[b] * L0[b]) >
                  shear[b] + friction * max(-axial, 0.0)):
                broke = 2
            else:
                broke = 0
            if broke:
                alive[b] = False
                snapped[n_snap] = b
                mode[n_snap] = broke
                n_snap += 1
                continue
        # f_j = -N e1 + V e2, e1 = d / L, e2 = (-dy, dx) / L, V = (M_i + M_j) / L
        a = N / L
        c = (M_i + M_j) / (L * L)
        gx = -a * dx - c * dy
        gy = -a * dy + c * dx
        fx -= gx
        fy -= gy
        m -= M_i
        if r < rows:
            out[r, 0] += gx
            out[r, 1] += gy
            out[r, 2] -= M_j
    if 0 <= cur < rows:
        out[cur, 0] += fx
        out[cur, 1] += fy
        out[cur, 2] += m
    return n_snap


def beam_forces(bonds, q, out, rows=None, accumulate=False, snapped=None, mode=None) -> int:
    """out[rows, 3] (+)= forces and torques of the live bonds of
    :class:`~solver.partitions.beam_bond.BeamBonds` ``bonds`` (sorted by i) at
    ``q`` [n, 3] = (u_x, u_y, theta); a breakable bond beyond its strength
    breaks first (alive False) and exerts nothing.  Returns how many broke:
    their indices in ``snapped`` and modes (1 tension, 2 shear) in ``mode``
    (arrays of at least as many entries as bonds; needed when any can
    break)."""
    if not accumulate:
        out[:] = 0.0
    if snapped is None:
        snapped = mode = _NONE
    return _loop(bonds.rest, q, bonds.i, bonds.j, bonds.L0, bonds.k_n, bonds.k_diag,
                 bonds.k_off, bonds.alive, bonds.tension, bonds.shear, bonds.bend,
                 bonds.friction, out, len(out) if rows is None else rows, snapped, mode)


_NONE = np.zeros(0, np.int64)
