"""The compiled loop of the 3D beam bonds (numba): one pass over the particles
for their rotation matrices R = exp([theta]x) and left Jacobians J, one over
the bonds.

The law is :mod:`solver.partitions.beam_bond3d`'s (a co-rotational beam of
circular section between rotating particles, measured in each end's frame);
this loop evaluates it for every bond b = (i, j) from the rest separation
dX_b and the particles' q = (u, theta) [n, 6], and adds the forces and the
torques conjugate to theta (J^T m, m the physical moment) to ``out`` [rows,
6] (rows >= ``rows`` are another piece's particles).  Called by
:mod:`solver.partitions.beam_force`; tests/test_beam_bond3d.py checks it
against the numpy law.
"""
from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True, boundscheck=False)
def _frames(q, R, J):
    """R[p] = exp([theta_p]x) and J[p] (the left Jacobian) of every particle."""
    for p in range(q.shape[0]):
        tx, ty, tz = q[p, 3], q[p, 4], q[p, 5]
        t2 = tx * tx + ty * ty + tz * tz
        if t2 < 1e-6:
            a = 1.0 - t2 / 6.0 + t2 * t2 / 120.0
            b = 0.5 - t2 / 24.0 + t2 * t2 / 720.0
            c = 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0
        else:
            t = np.sqrt(t2)
            s = np.sin(t)
            a = s / t
            b = (1.0 - np.cos(t)) / t2
            c = (t - s) / (t2 * t)
        th = (tx, ty, tz)
        for r in range(3):
            for k in range(3):
                ww = th[r] * th[k] - (t2 if r == k else 0.0)      # [theta]x^2
                R[p, r, k] = (1.0 if r == k else 0.0) + b * ww
                J[p, r, k] = (1.0 if r == k else 0.0) + c * ww
        # + a W (R), + b W (J), W = [theta]x
        R[p, 0, 1] -= a * tz
        R[p, 0, 2] += a * ty
        R[p, 1, 0] += a * tz
        R[p, 1, 2] -= a * tx
        R[p, 2, 0] -= a * ty
        R[p, 2, 1] += a * tx
        J[p, 0, 1] -= b * tz
        J[p, 0, 2] += b * ty
        J[p, 1, 0] += b * tz
        J[p, 1, 2] -= b * tx
        J[p, 2, 0] -= b * ty
        J[p, 2, 1] += b * tx


@numba.njit(cache=True, nogil=True, boundscheck=False)
def _loop(dX, q, R, J, i, j, L0, k_n, k_diag, k_off, k_t, alive, tension, shear, bend,
          friction, out, rows, snapped, mode):
    n_snap = 0
    d = np.empty(3)
    e0 = np.empty(3)
    g_i = np.empty(3)
    g_j = np.empty(3)
    h_i = np.empty(3)
    h_j = np.empty(3)
    P_i = np.empty(3)
    P_j = np.empty(3)
    w = np.empty(3)
    m_i = np.empty(3)
    m_j = np.empty(3)
    Q = np.empty((3, 3))
    for b in range(i.size):
        if not alive[b]:
            continue
        p, r = i[b], j[b]
        for c in range(3):
            d[c] = dX[b, c] + (q[r, c] - q[p, c])
            e0[c] = dX[b, c] / L0[b]
        L = np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        # a_e = R_e^T d; g_e = e0 x a_e / L
        ai0 = R[p, 0, 0] * d[0] + R[p, 1, 0] * d[1] + R[p, 2, 0] * d[2]
        ai1 = R[p, 0, 1] * d[0] + R[p, 1, 1] * d[1] + R[p, 2, 1] * d[2]
        ai2 = R[p, 0, 2] * d[0] + R[p, 1, 2] * d[1] + R[p, 2, 2] * d[2]
        aj0 = R[r, 0, 0] * d[0] + R[r, 1, 0] * d[1] + R[r, 2, 0] * d[2]
        aj1 = R[r, 0, 1] * d[0] + R[r, 1, 1] * d[1] + R[r, 2, 1] * d[2]
        aj2 = R[r, 0, 2] * d[0] + R[r, 1, 2] * d[1] + R[r, 2, 2] * d[2]
        g_i[0] = (e0[1] * ai2 - e0[2] * ai1) / L
        g_i[1] = (e0[2] * ai0 - e0[0] * ai2) / L
        g_i[2] = (e0[0] * ai1 - e0[1] * ai0) / L
        g_j[0] = (e0[1] * aj2 - e0[2] * aj1) / L
        g_j[1] = (e0[2] * aj0 - e0[0] * aj2) / L
        g_j[2] = (e0[0] * aj1 - e0[1] * aj0) / L
        # Q = R_i^T R_j: its trace, axial(skew Q) and Q^T e0
        for s in range(3):
            for t in range(3):
                Q[s, t] = R[p, 0, s] * R[r, 0, t] + R[p, 1, s] * R[r, 1, t] + \
                    R[p, 2, s] * R[r, 2, t]
        w[0] = 0.5 * (Q[2, 1] - Q[1, 2])
        w[1] = 0.5 * (Q[0, 2] - Q[2, 0])
        w[2] = 0.5 * (Q[1, 0] - Q[0, 1])
        tau = e0[0] * w[0] + e0[1] * w[1] + e0[2] * w[2]
        hh_i = hh_j = hs = hg = 0.0
        for c in range(3):
            h_i[c] = k_diag[b] * g_i[c] + k_off[b] * g_j[c]
            h_j[c] = k_off[b] * g_i[c] + k_diag[b] * g_j[c]
            hh_i += h_i[c] * h_i[c]
            hh_j += h_j[c] * h_j[c]
            hs += (h_i[c] + h_j[c]) ** 2
            hg += h_i[c] * g_i[c] + h_j[c] * g_j[c]
        N = k_n[b] * (L - L0[b])
        twist = k_t[b] * tau
        if tension[b] < np.inf:          # breakable (BeamBonds3D.breakable, failure)
            axial = (L - L0[b]) / L0[b]
            if axial + np.sqrt(max(hh_i, hh_j)) * bend[b] > tension[b]:
                broke = 1
            elif (np.sqrt(hs) / L / (k_n[b] * L0[b]) + abs(twist) * 0.5 * bend[b] >
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
        # P_e = R_e (h_e x e0) / L
        xi0 = h_i[1] * e0[2] - h_i[2] * e0[1]
        xi1 = h_i[2] * e0[0] - h_i[0] * e0[2]
        xi2 = h_i[0] * e0[1] - h_i[1] * e0[0]
        xj0 = h_j[1] * e0[2] - h_j[2] * e0[1]
        xj1 = h_j[2] * e0[0] - h_j[0] * e0[2]
        xj2 = h_j[0] * e0[1] - h_j[1] * e0[0]
        for c in range(3):
            P_i[c] = (R[p, c, 0] * xi0 + R[p, c, 1] * xi1 + R[p, c, 2] * xi2) / L
            P_j[c] = (R[r, c, 0] * xj0 + R[r, c, 1] * xj1 + R[r, c, 2] * xj2) / L
        # the twist's moment k_t tau R_i B^T e0, B^T e0 = (tr Q e0 - Q^T e0) / 2
        trQ = Q[0, 0] + Q[1, 1] + Q[2, 2]
        bt0 = 0.5 * (trQ * e0[0] - (Q[0, 0] * e0[0] + Q[1, 0] * e0[1] + Q[2, 0] * e0[2]))
        bt1 = 0.5 * (trQ * e0[1] - (Q[0, 1] * e0[0] + Q[1, 1] * e0[1] + Q[2, 1] * e0[2]))
        bt2 = 0.5 * (trQ * e0[2] - (Q[0, 2] * e0[0] + Q[1, 2] * e0[1] + Q[2, 2] * e0[2]))
        sc = (N - hg / L) / L
        for c in range(3):
            tw = twist * (R[p, c, 0] * bt0 + R[p, c, 1] * bt1 + R[p, c, 2] * bt2)
            c1, c2 = (c + 1) % 3, (c + 2) % 3
            m_i[c] = -(P_i[c1] * d[c2] - P_i[c2] * d[c1]) + tw
            m_j[c] = -(P_j[c1] * d[c2] - P_j[c2] * d[c1]) - tw
        for c in range(3):
            f = -(sc * d[c] + P_i[c] + P_j[c])                  # on j; -f on i
            if p < rows:
                out[p, c] -= f
                out[p, 3 + c] += J[p, 0, c] * m_i[0] + J[p, 1, c] * m_i[1] + J[p, 2, c] * m_i[2]
            if r < rows:
                out[r, c] += f
                out[r, 3 + c] += J[r, 0, c] * m_j[0] + J[r, 1, c] * m_j[1] + J[r, 2, c] * m_j[2]
    return n_snap


def beam_forces3d(bonds, q, out, rows=None, accumulate=False, snapped=None, mode=None) -> int:
    """out[rows, 6] (+)= forces and torques (conjugate to the rotation vectors)
    of the live bonds of :class:`~solver.partitions.beam_bond3d.BeamBonds3D`
    ``bonds`` at ``q`` [n, 6] = (u, theta); a breakable bond beyond its
    strength breaks first (alive False) and exerts nothing.  Returns how many
    broke, their indices in ``snapped`` and modes (1 tension, 2 shear) in
    ``mode``."""
    if not accumulate:
        out[:] = 0.0
    if snapped is None:
        snapped = mode = _NONE
    q = np.ascontiguousarray(q)
    R, J = np.empty((len(q), 3, 3)), np.empty((len(q), 3, 3))
    _frames(q, R, J)
    return _loop(bonds.rest, q, R, J, bonds.i, bonds.j, bonds.L0, bonds.k_n, bonds.k_diag,
                 bonds.k_off, bonds.k_t, bonds.alive, bonds.tension, bonds.shear, bonds.bend,
                 bonds.friction, out, len(out) if rows is None else rows, snapped, mode)


_NONE = np.zeros(0, np.int64)
