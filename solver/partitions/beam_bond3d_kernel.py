"""The compiled loop of the 3D beam bonds (numba): one pass over the particles
for their rotation matrices R = exp([theta]x) and left Jacobians J, one over
the bonds.

The law is :mod:`solver.partitions.beam_bond3d`'s (a co-rotational beam of
circular section between rotating particles, measured in each end's frame);
this loop evaluates it for every bond b = (i, j) from the rest separation
dX_b and the particles' q = (u, theta) [n, 6], and adds the forces and the
torques conjugate to theta (J^T m, m the physical moment, summed per
particle first) to ``out`` [rows, 6] (rows >= ``rows`` are another piece's
particles).  Bonds come sorted by their first particle, so its sums stay in
registers (as in :mod:`solver.partitions.bond_kernel`).  Called by
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
          friction, out, rows, snapped, mode, M):
    n_snap, cur = 0, -1
    fx = fy = fz = mx = my = mz = 0.0
    for b in range(i.size):
        p = i[b]
        if p != cur:                     # bonds sorted by i: p's sums stay in registers
            if 0 <= cur < rows:
                out[cur, 0] += fx
                out[cur, 1] += fy
                out[cur, 2] += fz
            if cur >= 0:
                M[cur, 0] += mx
                M[cur, 1] += my
                M[cur, 2] += mz
            cur = p
            fx = fy = fz = mx = my = mz = 0.0
        if not alive[b]:
            continue
        r = j[b]
        d0 = dX[b, 0] + (q[r, 0] - q[p, 0])
        d1 = dX[b, 1] + (q[r, 1] - q[p, 1])
        d2 = dX[b, 2] + (q[r, 2] - q[p, 2])
        inv0 = 1.0 / L0[b]
        e0, e1, e2 = dX[b, 0] * inv0, dX[b, 1] * inv0, dX[b, 2] * inv0
        L = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        iL = 1.0 / L
        # a_e = R_e^T d; g_e = e0 x a_e / L
        ai0 = R[p, 0, 0] * d0 + R[p, 1, 0] * d1 + R[p, 2, 0] * d2
        ai1 = R[p, 0, 1] * d0 + R[p, 1, 1] * d1 + R[p, 2, 1] * d2
        ai2 = R[p, 0, 2] * d0 + R[p, 1, 2] * d1 + R[p, 2, 2] * d2
        aj0 = R[r, 0, 0] * d0 + R[r, 1, 0] * d1 + R[r, 2, 0] * d2
        aj1 = R[r, 0, 1] * d0 + R[r, 1, 1] * d1 + R[r, 2, 1] * d2
        aj2 = R[r, 0, 2] * d0 + R[r, 1, 2] * d1 + R[r, 2, 2] * d2
        gi0, gi1, gi2 = (e1 * ai2 - e2 * ai1) * iL, (e2 * ai0 - e0 * ai2) * iL, \
            (e0 * ai1 - e1 * ai0) * iL
        gj0, gj1, gj2 = (e1 * aj2 - e2 * aj1) * iL, (e2 * aj0 - e0 * aj2) * iL, \
            (e0 * aj1 - e1 * aj0) * iL
        # Q = R_i^T R_j: Q_st = R_i[:, s] . R_j[:, t]
        q00 = R[p, 0, 0] * R[r, 0, 0] + R[p, 1, 0] * R[r, 1, 0] + R[p, 2, 0] * R[r, 2, 0]
        q01 = R[p, 0, 0] * R[r, 0, 1] + R[p, 1, 0] * R[r, 1, 1] + R[p, 2, 0] * R[r, 2, 1]
        q02 = R[p, 0, 0] * R[r, 0, 2] + R[p, 1, 0] * R[r, 1, 2] + R[p, 2, 0] * R[r, 2, 2]
        q10 = R[p, 0, 1] * R[r, 0, 0] + R[p, 1, 1] * R[r, 1, 0] + R[p, 2, 1] * R[r, 2, 0]
        q11 = R[p, 0, 1] * R[r, 0, 1] + R[p, 1, 1] * R[r, 1, 1] + R[p, 2, 1] * R[r, 2, 1]
        q12 = R[p, 0, 1] * R[r, 0, 2] + R[p, 1, 1] * R[r, 1, 2] + R[p, 2, 1] * R[r, 2, 2]
        q20 = R[p, 0, 2] * R[r, 0, 0] + R[p, 1, 2] * R[r, 1, 0] + R[p, 2, 2] * R[r, 2, 0]
        q21 = R[p, 0, 2] * R[r, 0, 1] + R[p, 1, 2] * R[r, 1, 1] + R[p, 2, 2] * R[r, 2, 1]
        q22 = R[p, 0, 2] * R[r, 0, 2] + R[p, 1, 2] * R[r, 1, 2] + R[p, 2, 2] * R[r, 2, 2]
        tau = 0.5 * (e0 * (q21 - q12) + e1 * (q02 - q20) + e2 * (q10 - q01))
        kd, ko = k_diag[b], k_off[b]
        hi0, hi1, hi2 = kd * gi0 + ko * gj0, kd * gi1 + ko * gj1, kd * gi2 + ko * gj2
        hj0, hj1, hj2 = ko * gi0 + kd * gj0, ko * gi1 + kd * gj1, ko * gi2 + kd * gj2
        N = k_n[b] * (L - L0[b])
        twist = k_t[b] * tau
        if tension[b] < np.inf:          # breakable (BeamBonds3D.breakable, failure)
            axial = (L - L0[b]) * inv0
            hh = max(hi0 * hi0 + hi1 * hi1 + hi2 * hi2, hj0 * hj0 + hj1 * hj1 + hj2 * hj2)
            s0, s1, s2 = hi0 + hj0, hi1 + hj1, hi2 + hj2
            if axial + np.sqrt(hh) * bend[b] > tension[b]:
                broke = 1
            elif (np.sqrt(s0 * s0 + s1 * s1 + s2 * s2) * iL / (k_n[b] * L0[b]) +
                  abs(twist) * 0.5 * bend[b] > shear[b] + friction * max(-axial, 0.0)):
                broke = 2
            else:
                broke = 0
            if broke:
                alive[b] = False
                snapped[n_snap] = b
                mode[n_snap] = broke
                n_snap += 1
                continue
        hg = (hi0 * gi0 + hi1 * gi1 + hi2 * gi2 + hj0 * gj0 + hj1 * gj1 + hj2 * gj2)
        # P_e = R_e (h_e x e0) / L
        xi0, xi1, xi2 = hi1 * e2 - hi2 * e1, hi2 * e0 - hi0 * e2, hi0 * e1 - hi1 * e0
        xj0, xj1, xj2 = hj1 * e2 - hj2 * e1, hj2 * e0 - hj0 * e2, hj0 * e1 - hj1 * e0
        Pi0 = (R[p, 0, 0] * xi0 + R[p, 0, 1] * xi1 + R[p, 0, 2] * xi2) * iL
        Pi1 = (R[p, 1, 0] * xi0 + R[p, 1, 1] * xi1 + R[p, 1, 2] * xi2) * iL
        Pi2 = (R[p, 2, 0] * xi0 + R[p, 2, 1] * xi1 + R[p, 2, 2] * xi2) * iL
        Pj0 = (R[r, 0, 0] * xj0 + R[r, 0, 1] * xj1 + R[r, 0, 2] * xj2) * iL
        Pj1 = (R[r, 1, 0] * xj0 + R[r, 1, 1] * xj1 + R[r, 1, 2] * xj2) * iL
        Pj2 = (R[r, 2, 0] * xj0 + R[r, 2, 1] * xj1 + R[r, 2, 2] * xj2) * iL
        # the twist's moment k_t tau R_i B^T e0, B^T e0 = (tr Q e0 - Q^T e0) / 2
        trQ = q00 + q11 + q22
        bt0 = 0.5 * (trQ * e0 - (q00 * e0 + q10 * e1 + q20 * e2))
        bt1 = 0.5 * (trQ * e1 - (q01 * e0 + q11 * e1 + q21 * e2))
        bt2 = 0.5 * (trQ * e2 - (q02 * e0 + q12 * e1 + q22 * e2))
        tw0 = twist * (R[p, 0, 0] * bt0 + R[p, 0, 1] * bt1 + R[p, 0, 2] * bt2)
        tw1 = twist * (R[p, 1, 0] * bt0 + R[p, 1, 1] * bt1 + R[p, 1, 2] * bt2)
        tw2 = twist * (R[p, 2, 0] * bt0 + R[p, 2, 1] * bt1 + R[p, 2, 2] * bt2)
        sc = (N - hg * iL) * iL
        f0 = -(sc * d0 + Pi0 + Pj0)                            # on j; -f on i
        f1 = -(sc * d1 + Pi1 + Pj1)
        f2 = -(sc * d2 + Pi2 + Pj2)
        fx -= f0
        fy -= f1
        fz -= f2
        mx += -(Pi1 * d2 - Pi2 * d1) + tw0                     # physical moments m = -P x d
        my += -(Pi2 * d0 - Pi0 * d2) + tw1
        mz += -(Pi0 * d1 - Pi1 * d0) + tw2
        if r < rows:
            out[r, 0] += f0
            out[r, 1] += f1
            out[r, 2] += f2
        M[r, 0] += -(Pj1 * d2 - Pj2 * d1) - tw0
        M[r, 1] += -(Pj2 * d0 - Pj0 * d2) - tw1
        M[r, 2] += -(Pj0 * d1 - Pj1 * d0) - tw2
    if 0 <= cur < rows:
        out[cur, 0] += fx
        out[cur, 1] += fy
        out[cur, 2] += fz
    if cur >= 0:
        M[cur, 0] += mx
        M[cur, 1] += my
        M[cur, 2] += mz
    for p in range(rows):                # the torques conjugate to theta: J^T m
        for c in range(3):
            out[p, 3 + c] += J[p, 0, c] * M[p, 0] + J[p, 1, c] * M[p, 1] + J[p, 2, c] * M[p, 2]
    return n_snap


def beam_forces3d(bonds, q, out, rows=None, accumulate=False, snapped=None, mode=None,
                  frames=None) -> int:
    """out[rows, 6] (+)= forces and torques (conjugate to the rotation vectors)
    of the live bonds of :class:`~solver.partitions.beam_bond3d.BeamBonds3D`
    ``bonds`` at ``q`` [n, 6] = (u, theta); a breakable bond beyond its
    strength breaks first (alive False) and exerts nothing.  Returns how many
    broke, their indices in ``snapped`` and modes (1 tension, 2 shear) in
    ``mode``.  ``frames``: :func:`buffers` of len(q) particles to fill (a
    caller stepping many times keeps one; default: new ones)."""
    if not accumulate:
        out[:] = 0.0
    if snapped is None:
        snapped = mode = _NONE
    q = np.ascontiguousarray(q)
    R, J, M = frames if frames is not None else buffers(len(q))
    _frames(q, R, J)
    M[:] = 0.0
    return _loop(bonds.rest, q, R, J, bonds.i, bonds.j, bonds.L0, bonds.k_n, bonds.k_diag,
                 bonds.k_off, bonds.k_t, bonds.alive, bonds.tension, bonds.shear, bonds.bend,
                 bonds.friction, out, len(out) if rows is None else rows, snapped, mode, M)


def buffers(m: int):
    """(R, J, M): the rotation matrices, Jacobians [m, 3, 3] and physical
    moments [m, 3] of :func:`beam_forces3d`'s m particles."""
    return np.empty((m, 3, 3)), np.empty((m, 3, 3)), np.empty((m, 3))


_NONE = np.zeros(0, np.int64)
