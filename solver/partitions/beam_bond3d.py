"""Beam bonds between rotating particles in 3D: the bond law of the
bonded-particle model with rotations in solids (``model.lattice.bond: beam``;
the 2D law is :mod:`solver.partitions.beam_bond`, the compiled loop
:mod:`solver.partitions.beam_bond3d_kernel`).

A particle carries its displacement u and its orientation R, a rotation
matrix: in a partition, that of :class:`solver.partitions.orientation.Orientation`,
which its rotation DOFs advance; the methods here take either the matrices
[m, 3, 3] or rotation vectors theta [m, 3] (R = exp([theta]x), Rodrigues'
formula).  A bond (i, j) at rest
D = X_j - X_i (length L0, direction e0) is a co-rotational beam of circular
section, measured in each end's own frame, so that a rigid motion of the two
particles (any translation, any rotation) leaves every measure, and hence
every force, at zero:

    d = D + u_j - u_i,  L = |d|
    g_e = e0 x (R_e^T d) / L           end e's tilt against the chord (e = i, j)
    tau = e0 . axial(skew(R_i^T R_j))  the twist of j against i about the bond
    E = 1/2 k_n (L - L0)^2 + 1/2 k_d (|g_i|^2 + |g_j|^2) + k_o g_i . g_j + 1/2 k_t tau^2

with k_d = k_b (4 + Phi) / (1 + Phi), k_o = k_b (2 - Phi) / (1 + Phi) the 2D
law's bending entries (k_b = E_b I / L0, Phi the shear parameter) and
k_t = G_b J / L0 the torsional stiffness.  In a plane this is the 2D law with
sin(phi) for phi (g_e = -sin(phi_e) along the plane's normal), and for
small motions the Timoshenko beam element in each bending plane with
torsion (tests/test_beam_bond3d.py checks it against
:func:`solver.model.calibration.beam_blocks3d`).

Forces and moments are the energy's exact gradients: f = -dE/du, and the
moment m on a particle the energy's rate under a spin dw of it (dE = -m . dw
for dR = [dw]x R), the torque its angular velocity's equation takes (in
a rotation vector's terms, J(theta)^T m, J the left Jacobian).  The loads
(h_e = dE/dg_e, the bending moment at end e):

    h_i = k_d g_i + k_o g_j,  h_j = k_o g_i + k_d g_j,  P_e = R_e (h_e x e0) / L
    dE/dd = [k_n (L - L0) - sum_e h_e . g_e / L] d / L + sum_e P_e
    f_j = -dE/dd,  f_i = dE/dd
    m_e = -P_e x d (bending),  twist: +k_t tau R_i B^T e0 on i, minus that on j,
    B = 1/2 (tr(Q) I - Q), Q = R_i^T R_j  (d axial(skew Q) = B a for dQ = [a]x Q)

Breakage (:meth:`BeamBonds3D.breakable`) is the parallel bond's on a circular
section of radius c = 2 sqrt(I / A): the most stretched fibre's strain
(L - L0)/L0 + max |h_e| c / (E_b I), and the shear strain |h_i + h_j| / L /
(E_b A) + |k_t tau| c / (E_b J) (J = 2 I) against a Mohr-Coulomb limit.
Numpy over arrays of bonds.
"""
from __future__ import annotations

import numpy as np


def _cross(a):
    """[n, 3, 3]: the cross-product matrices [a]x of vectors a [n, 3]."""
    z = np.zeros(len(a))
    return np.stack([np.stack([z, -a[:, 2], a[:, 1]], 1),
                     np.stack([a[:, 2], z, -a[:, 0]], 1),
                     np.stack([-a[:, 1], a[:, 0], z], 1)], 1)


def _coefficients(t):
    """(sin t / t, (1 - cos t) / t^2) of angles t >= 0, their series below
    1e-3 (round-off otherwise)."""
    small = t < 1e-3
    s = np.where(small, 1.0, t)
    t2 = t * t
    a = np.where(small, 1.0 - t2 / 6.0 + t2 * t2 / 120.0, np.sin(s) / s)
    b = np.where(small, 0.5 - t2 / 24.0 + t2 * t2 / 720.0, (1.0 - np.cos(s)) / s ** 2)
    return a, b


def rotations(theta):
    """[n, 3, 3]: R = exp([theta]x) of rotation vectors ``theta`` [n, 3]."""
    theta = np.asarray(theta, float).reshape(-1, 3)
    a, b = _coefficients(np.linalg.norm(theta, axis=1))
    W = _cross(theta)
    return np.eye(3) + a[:, None, None] * W + b[:, None, None] * (W @ W)


def frames(rot) -> np.ndarray:
    """[m, 3, 3]: rotation matrices ``rot`` as they are, or those of rotation
    vectors ``rot`` [m, 3]."""
    rot = np.asarray(rot, float)
    return rot if rot.ndim == 3 else rotations(rot)


def _axial(Q):
    """axial(skew(Q)) of matrices Q [n, 3, 3]."""
    return 0.5 * np.stack([Q[:, 2, 1] - Q[:, 1, 2], Q[:, 0, 2] - Q[:, 2, 0],
                           Q[:, 1, 0] - Q[:, 0, 1]], axis=1)


class BeamBonds3D:
    """The 3D beam bonds (i, j) with rest separations ``rest`` [n, 3], axial
    stiffness k_n, bending k_b, torsion k_t and shear parameters Phi (arrays
    or scalars)."""

    def __init__(self, i, j, rest, k_n, k_b, k_t, phi=0.0):
        self.i, self.j = np.asarray(i, np.int64), np.asarray(j, np.int64)
        self.rest = np.asarray(rest, dtype=float)
        n = self.i.size
        self.L0 = np.linalg.norm(self.rest, axis=1)
        self.e0 = self.rest / self.L0[:, None]
        self.k_n = np.array(np.broadcast_to(np.asarray(k_n, float), (n,)))   # contiguous
        k_b = np.broadcast_to(np.asarray(k_b, float), (n,))
        Phi = np.broadcast_to(np.asarray(phi, float), (n,))
        self.k_diag = k_b * (4.0 + Phi) / (1.0 + Phi)
        self.k_off = k_b * (2.0 - Phi) / (1.0 + Phi)
        self.k_t = np.array(np.broadcast_to(np.asarray(k_t, float), (n,)))
        self.alive = np.ones(n, bool)
        self.tension = np.full(n, np.inf)
        self.shear = np.full(n, np.inf)
        self.friction = 0.0
        # c / (E_b I) of a circular section: c = 2 sqrt(I / A), E_b I = k_b L0,
        # E_b A = k_n L0
        with np.errstate(divide="ignore", invalid="ignore"):
            self.bend = np.where(k_b > 0, 2.0 * np.sqrt(k_b / self.k_n) / (k_b * self.L0), 0.0)

    def breakable(self, tension, shear, friction: float = 0.0):
        """Strengths as :meth:`solver.partitions.beam_bond.BeamBonds.breakable`
        (the shear strain with the twist's, see the module)."""
        n = self.i.size
        self.tension = np.array(np.broadcast_to(np.asarray(tension, float), (n,)))
        self.shear = np.array(np.broadcast_to(np.asarray(shear, float), (n,)))
        self.friction = float(friction)

    def _measures(self, u, rot):
        """(d, L, R_i, R_j, g_i, g_j, tau, Q) at displacements ``u`` [m, 3] and
        orientations ``rot`` (matrices [m, 3, 3] or rotation vectors [m, 3])."""
        d = self.rest + (u[self.j] - u[self.i])
        L = np.linalg.norm(d, axis=1)
        R = frames(rot)
        R_i, R_j = R[self.i], R[self.j]
        g_i = np.cross(self.e0, np.einsum("bki,bk->bi", R_i, d)) / L[:, None]
        g_j = np.cross(self.e0, np.einsum("bki,bk->bi", R_j, d)) / L[:, None]
        Q = np.einsum("bki,bkj->bij", R_i, R_j)
        tau = np.einsum("bi,bi->b", self.e0, _axial(Q))
        return d, L, R_i, R_j, g_i, g_j, tau, Q

    def _moments(self, g_i, g_j):
        h_i = self.k_diag[:, None] * g_i + self.k_off[:, None] * g_j
        h_j = self.k_off[:, None] * g_i + self.k_diag[:, None] * g_j
        return h_i, h_j

    def failure(self, u, rot):
        """(tension strain, shear strain, their limits) of every bond."""
        d, L, _, _, g_i, g_j, tau, _ = self._measures(u, rot)
        h_i, h_j = self._moments(g_i, g_j)
        axial = (L - self.L0) / self.L0
        fibre = axial + np.maximum(np.linalg.norm(h_i, axis=1),
                                   np.linalg.norm(h_j, axis=1)) * self.bend
        slip = (np.linalg.norm(h_i + h_j, axis=1) / L / (self.k_n * self.L0) +
                np.abs(self.k_t * tau) * 0.5 * self.bend)
        return fibre, slip, self.tension, self.shear + self.friction * np.maximum(-axial, 0.0)

    def subset(self, bonds) -> "BeamBonds3D":
        """The bonds ``bonds`` (an index or mask) alone, on the same particles."""
        sub = BeamBonds3D.__new__(BeamBonds3D)
        for name in ("i", "j", "rest", "L0", "e0", "k_n", "k_diag", "k_off", "k_t", "alive",
                     "tension", "shear", "bend"):
            setattr(sub, name, getattr(self, name)[bonds])
        sub.friction = self.friction
        return sub

    def energies(self, u, rot) -> np.ndarray:
        """Each bond's strain energy."""
        _, L, _, _, g_i, g_j, tau, _ = self._measures(u, rot)
        bend = (self.k_diag * (np.sum(g_i * g_i, axis=1) + np.sum(g_j * g_j, axis=1)) +
                2.0 * self.k_off * np.sum(g_i * g_j, axis=1))
        return 0.5 * (self.k_n * (L - self.L0) ** 2 + bend + self.k_t * tau ** 2)

    def energy(self, u, rot) -> float:
        """The live bonds' strain energy."""
        return float(np.sum(self.energies(u, rot)[self.alive]))

    def loads(self, u, rot):
        """(f_j [n, 3], m_i [n, 3], m_j [n, 3]): each bond's force on its
        second particle (minus that on the first) and its physical moments on
        both ends."""
        d, L, R_i, R_j, g_i, g_j, tau, Q = self._measures(u, rot)
        h_i, h_j = self._moments(g_i, g_j)
        P_i = np.einsum("bij,bj->bi", R_i, np.cross(h_i, self.e0)) / L[:, None]
        P_j = np.einsum("bij,bj->bi", R_j, np.cross(h_j, self.e0)) / L[:, None]
        hg = np.sum(h_i * g_i, axis=1) + np.sum(h_j * g_j, axis=1)
        dEdd = ((self.k_n * (L - self.L0) - hg / L) / L)[:, None] * d + P_i + P_j
        B = 0.5 * (np.trace(Q, axis1=1, axis2=2)[:, None, None] * np.eye(3) - Q)
        twist = (self.k_t * tau)[:, None] * np.einsum("bij,bkj,bk->bi", R_i, B, self.e0)
        return -dEdd, -np.cross(P_i, d) + twist, -np.cross(P_j, d) - twist

    def resultants(self, u, rot):
        """Each bond's (axial force N, shear force |V|, bending moments |M_i|,
        |M_j|, twisting moment T)."""
        d, L, _, _, g_i, g_j, tau, _ = self._measures(u, rot)
        h_i, h_j = self._moments(g_i, g_j)
        return (self.k_n * (L - self.L0), np.linalg.norm(h_i + h_j, axis=1) / L,
                np.linalg.norm(h_i, axis=1), np.linalg.norm(h_j, axis=1), self.k_t * tau)

    def virial(self, u, rot, bonds, c) -> float:
        """sum over ``bonds`` of f_c d_c, f the bond's force on its first
        particle, d = x_j - x_i."""
        sub = self.subset(bonds)
        d = sub.rest + (u[sub.j] - u[sub.i])
        f_j, _, _ = sub.loads(u, rot)
        return float(np.sum(np.where(sub.alive, -f_j[:, c] * d[:, c], 0.0)))

    def forces(self, u, rot, m=None):
        """(forces [m, 3], moments [m, 3]) of the live bonds on the particles
        at displacements ``u`` and orientations ``rot``."""
        f_j, m_i, m_j = (np.where(self.alive[:, None], x, 0.0) for x in self.loads(u, rot))
        m = len(u) if m is None else m
        force, moment = np.zeros((m, 3)), np.zeros((m, 3))
        for c in range(3):
            force[:, c] = (np.bincount(self.j, f_j[:, c], minlength=m) -
                           np.bincount(self.i, f_j[:, c], minlength=m))
            moment[:, c] = (np.bincount(self.i, m_i[:, c], minlength=m) +
                            np.bincount(self.j, m_j[:, c], minlength=m))
        return force, moment
