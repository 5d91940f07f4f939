"""The compiled loop of the 3D beam bonds (numba): one pass over the particles
for their rotation matrices, one over the bonds.

The law is :mod:`solver.partitions.beam_bond3d`'s (a co-rotational beam of
circular section between rotating particles, measured in each end's frame);
this loop evaluates it for every bond b = (i, j) from the rest separation
dX_b, the particles' q = (u, theta) [n, 6] and their orientations
(:class:`solver.partitions.orientation.Orientation`: R = exp([theta -
theta_last]x) R(quat), composed here as quaternions), and adds the forces and
moments to ``out`` [rows, 6] (rows >= ``rows`` are another piece's
particles).  Bonds come sorted by their first particle, so its sums stay in
registers (as in :mod:`solver.partitions.bond_kernel`).  Called by
:mod:`solver.partitions.beam_force`; tests/test_beam_bond3d.py checks it
against the numpy law.
"""
from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True, boundscheck=False)
def _frames(q, last, quat, R, turned):
    """R[p]: the orientation of particle p at q, the quaternion quat[p] (at
    rotation DOFs last[p]) turned by the increment q[p, 3:] - last[p]; that
    turned quaternion (normalised) into turned[p]."""
    for p in range(R.shape[0]):
        dx, dy, dz = q[p, 3] - last[p, 0], q[p, 4] - last[p, 1], q[p, 5] - last[p, 2]
        h2 = 0.25 * (dx * dx + dy * dy + dz * dz)          # (half the angle)^2
        if h2 < 1e-8:
            c = 1.0 - 0.5 * h2 + h2 * h2 / 24.0
            s = 0.5 * (1.0 - h2 / 6.0 + h2 * h2 / 120.0)
        else:
            h = np.sqrt(h2)
            c = np.cos(h)
            s = 0.5 * np.sin(h) / h
        x, y, z = s * dx, s * dy, s * dz
        w0, x0, y0, z0 = quat[p, 0], quat[p, 1], quat[p, 2], quat[p, 3]
        w = c * w0 - (x * x0 + y * y0 + z * z0)            # (c, x, y, z) quat[p]
        a = c * x0 + w0 * x + (y * z0 - z * y0)
        b = c * y0 + w0 * y + (z * x0 - x * z0)
        e = c * z0 + w0 * z + (x * y0 - y * x0)
        n = 1.0 / (w * w + a * a + b * b + e * e)
        n2 = 2.0 * n                                       # 2 / |q|^2: normalised
        k = np.sqrt(n)
        turned[p, 0], turned[p, 1], turned[p, 2], turned[p, 3] = w * k, a * k, b * k, e * k
        R[p, 0, 0] = 1.0 - n2 * (b * b + e * e)
        R[p, 0, 1] = n2 * (a * b - w * e)
        R[p, 0, 2] = n2 * (a * e + w * b)
        R[p, 1, 0] = n2 * (a * b + w * e)
        R[p, 1, 1] = 1.0 - n2 * (a * a + e * e)
        R[p, 1, 2] = n2 * (b * e - w * a)
        R[p, 2, 0] = n2 * (a * e - w * b)
        R[p, 2, 1] = n2 * (b * e + w * a)
        R[p, 2, 2] = 1.0 - n2 * (a * a + b * b)


@numba.njit(cache=True, nogil=True, boundscheck=False, inline="always")
def _flush(out, p, fx, fy, fz, mx, my, mz):
    """out[p] += (force, moment)."""
    out[p, 0] += fx
    out[p, 1] += fy
    out[p, 2] += fz
    out[p, 3] += mx
    out[p, 4] += my
    out[p, 5] += mz


@numba.njit(cache=True, nogil=True, boundscheck=False)
def _loop(dX, q, R, i, j, L0, k_n, k_diag, k_off, k_t, alive, tension, shear, bend,
          friction, out, rows, snapped, mode):
    n_snap, cur = 0, -1
    fx = fy = fz = mx = my = mz = 0.0
    for b in range(i.size):
        p = i[b]
        if p != cur:                     # bonds sorted by i: p's sums stay in registers
            if 0 <= cur < rows:
                _flush(out, cur, fx, fy, fz, mx, my, mz)
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
            _flush(out, r, f0, f1, f2, -(Pj1 * d2 - Pj2 * d1) - tw0,
                   -(Pj2 * d0 - Pj0 * d2) - tw1, -(Pj0 * d1 - Pj1 * d0) - tw2)
    if 0 <= cur < rows:
        _flush(out, cur, fx, fy, fz, mx, my, mz)
    return n_snap


def beam_forces3d(bonds, q, out, rows=None, accumulate=False, snapped=None, mode=None,
                  orientation=None, R=None) -> int:
    """out[rows, 6] (+)= forces and moments of the live bonds of
    :class:`~solver.partitions.beam_bond3d.BeamBonds3D` ``bonds`` at ``q``
    [n, 6] = (u, theta) and ``orientation`` (an
    :class:`~solver.partitions.orientation.Orientation` of the first m
    particles, those the bonds join, its ``turned`` filled with the
    orientations at q: :meth:`~solver.partitions.orientation.Orientation.keep`
    keeps them; None: R = exp([theta]x)); a breakable
    bond beyond its strength breaks first (alive False) and exerts nothing.
    Returns how many broke, their indices in ``snapped`` and modes (1
    tension, 2 shear) in ``mode``.  ``R``: an [m, 3, 3] buffer for the
    rotation matrices (a caller stepping many times keeps one; default: a
    new one)."""
    if not accumulate:
        out[:] = 0.0
    if snapped is None:
        snapped = mode = _NONE
    q = np.ascontiguousarray(q)
    if orientation is None:
        quat, last = np.zeros((len(q), 4)), np.zeros((len(q), 3))
        quat[:, 0] = 1.0
        turned = np.empty_like(quat)
    else:
        quat, last, turned = orientation.quat, orientation.last, orientation.turned
    if R is None:
        R = np.empty((len(quat), 3, 3))
    _frames(q, last, quat, R, turned)
    return _loop(bonds.rest, q, R, bonds.i, bonds.j, bonds.L0, bonds.k_n, bonds.k_diag,
                 bonds.k_off, bonds.k_t, bonds.alive, bonds.tension, bonds.shear, bonds.bend,
                 bonds.friction, out, len(out) if rows is None else rows, snapped, mode)


_NONE = np.zeros(0, np.int64)
