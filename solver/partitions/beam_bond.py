"""Beam bonds between rotating particles in 2D: the bond law of the
bonded-particle model with rotations (``model.lattice.bond: beam``; the
partitions step it through :mod:`solver.partitions.beam_force` and the
compiled loop of :mod:`solver.partitions.beam_bond_kernel`).

A bond (i, j) joins two particles with positions x and rotations theta, at
rest X_j - X_i (length L0, direction angle alpha0).  It is a co-rotational
Timoshenko beam (the bond of Potyondy & Cundall's parallel-bond model, in
the total rather than incremental form, as in the beam-lattice models of
fracture):

    d = x_j - x_i,  L = |d|,  e1 = d / L,  e2 = e1 turned by +90 degrees
    beta  = angle(d) - alpha0             the chord's rotation (wrapped)
    phi_i = wrap(theta_i - beta),  phi_j = wrap(theta_j - beta)
    E = 1/2 k_n (L - L0)^2 + 1/2 [phi_i phi_j] K_b [phi_i phi_j]^T
    K_b = k_b / (1 + Phi) [[4 + Phi, 2 - Phi], [2 - Phi, 4 + Phi]]

with k_n = E_b A / L0, k_b = E_b I / L0 and Phi = 12 E_b I / (kappa G A L0^2)
the beam's shear parameter (0: Euler-Bernoulli).  The forces and torques
are the energy's gradients, so the law conserves energy under a
symplectic integrator, and a rigid motion of the two particles (any
translation, any rotation: beta and both thetas turn together) leaves phi,
L and hence every force at zero:

    N = k_n (L - L0)              axial force (tension > 0)
    [M_i, M_j] = K_b [phi_i, phi_j]   end moments
    V = (M_i + M_j) / L           shear force
    f_j = -N e1 + V e2,  f_i = -f_j,  torque_i = -M_i,  torque_j = -M_j

An end turned by more than pi against the chord wraps round (its moment
changes sign there): a bond bent that far has broken long before.
For small motions this is the Timoshenko beam element's stiffness matrix
(tests/test_beam_bond.py checks it and the large-deflection cantilever
against the elastica).  Numpy over arrays of bonds.
"""
from __future__ import annotations

import numpy as np


def wrap(angle):
    """The angle in (-pi, pi]."""
    return np.pi - np.mod(np.pi - angle, 2.0 * np.pi)


class BeamBonds:
    """The 2D beam bonds (i, j) with rest separations ``rest`` [n, 2] and the
    stiffnesses k_n, k_b and shear parameters Phi (arrays or scalars)."""

    def __init__(self, i, j, rest, k_n, k_b, phi=0.0):
        self.i, self.j = np.asarray(i, np.int64), np.asarray(j, np.int64)
        self.rest = np.asarray(rest, dtype=float)
        n = self.i.size
        self.L0 = np.linalg.norm(self.rest, axis=1)
        self.alpha0 = np.arctan2(self.rest[:, 1], self.rest[:, 0])
        self.k_n = np.array(np.broadcast_to(np.asarray(k_n, float), (n,)))   # contiguous
        k_b = np.broadcast_to(np.asarray(k_b, float), (n,))
        Phi = np.broadcast_to(np.asarray(phi, float), (n,))
        self.k_diag = k_b * (4.0 + Phi) / (1.0 + Phi)          # K_b's entries
        self.k_off = k_b * (2.0 - Phi) / (1.0 + Phi)
        # breakage (:meth:`breakable`): unbreakable until given strengths
        self.alive = np.ones(n, bool)
        self.tension = np.full(n, np.inf)      # critical strain of the most stretched fibre
        self.shear = np.full(n, np.inf)        # critical |V| / (k_n L0) (shear stress / E_b)
        self.friction = 0.0                    # tan of the Mohr-Coulomb friction angle
        # the outer fibre's bending strain per unit end moment, c / (E_b I): a
        # rectangular section of the beam's A and I has c = sqrt(3 I / A), and
        # E_b I = k_b L0, E_b A = k_n L0
        with np.errstate(divide="ignore", invalid="ignore"):
            self.bend = np.where(k_b > 0, np.sqrt(3.0 * k_b / self.k_n) / (k_b * self.L0), 0.0)

    def breakable(self, tension, shear, friction: float = 0.0):
        """Give the bonds strengths (Potyondy & Cundall's parallel bond, in
        strains of the bond's material E_b): a bond breaks in tension when
        its most stretched fibre's strain, (L - L0)/L0 + max(|M_i|, |M_j|)
        c / (E_b I), exceeds ``tension``; in shear when |V| / (E_b A)
        exceeds ``shear`` + ``friction`` x its axial compression strain
        (Mohr-Coulomb)."""
        n = self.i.size
        self.tension = np.array(np.broadcast_to(np.asarray(tension, float), (n,)))
        self.shear = np.array(np.broadcast_to(np.asarray(shear, float), (n,)))
        self.friction = float(friction)

    def failure(self, u, theta):
        """(tension strain, shear strain, their limits) of every bond (see
        :meth:`breakable`): it breaks where a strain exceeds its limit."""
        L, _, _, N, M_i, M_j = self._loads(u, theta)
        axial = (L - self.L0) / self.L0
        fibre = axial + np.maximum(np.abs(M_i), np.abs(M_j)) * self.bend
        slip = np.abs(M_i + M_j) / L / (self.k_n * self.L0)
        return fibre, slip, self.tension, self.shear + self.friction * np.maximum(-axial, 0.0)

    def state(self, u, theta):
        """(d, L, e1, e2, phi_i, phi_j) at displacements ``u`` [m, 2] and
        rotations ``theta`` [m], from the rest separations (no X + u)."""
        d = self.rest + (u[self.j] - u[self.i])
        L = np.linalg.norm(d, axis=1)
        e1 = d / L[:, None]
        e2 = np.stack([-e1[:, 1], e1[:, 0]], axis=1)
        beta = wrap(np.arctan2(d[:, 1], d[:, 0]) - self.alpha0)
        return d, L, e1, e2, wrap(theta[self.i] - beta), wrap(theta[self.j] - beta)

    def _loads(self, u, theta):
        """(L, e1, e2, N, M_i, M_j) of each bond at ``u``, ``theta``."""
        _, L, e1, e2, phi_i, phi_j = self.state(u, theta)
        M_i = self.k_diag * phi_i + self.k_off * phi_j
        M_j = self.k_off * phi_i + self.k_diag * phi_j
        return L, e1, e2, self.k_n * (L - self.L0), M_i, M_j

    def subset(self, bonds) -> "BeamBonds":
        """The bonds ``bonds`` (an index or mask) alone, on the same particles."""
        sub = BeamBonds.__new__(BeamBonds)
        for name in ("i", "j", "rest", "L0", "alpha0", "k_n", "k_diag", "k_off", "alive",
                     "tension", "shear", "bend"):
            setattr(sub, name, getattr(self, name)[bonds])
        sub.friction = self.friction
        return sub

    def virial(self, u, theta, bonds, c) -> float:
        """sum over ``bonds`` of f_c d_c, f = N e1 - V e2 (the force on the
        first particle, towards the second in tension), d = x_j - x_i."""
        sub = self.subset(bonds)
        d = sub.rest + (u[sub.j] - u[sub.i])
        L, e1, e2, N, M_i, M_j = sub._loads(u, theta)
        f = N[:, None] * e1 - ((M_i + M_j) / L)[:, None] * e2
        return float(np.sum(np.where(sub.alive, f[:, c] * d[:, c], 0.0)))

    def resultants(self, u, theta):
        """Each bond's (axial force N, shear force V, end moments M_i, M_j)."""
        L, _, _, N, M_i, M_j = self._loads(u, theta)
        return N, (M_i + M_j) / L, M_i, M_j

    def energies(self, u, theta) -> np.ndarray:
        """Each bond's strain energy."""
        _, L, _, _, phi_i, phi_j = self.state(u, theta)
        bend = self.k_diag * (phi_i ** 2 + phi_j ** 2) + 2.0 * self.k_off * phi_i * phi_j
        return 0.5 * self.k_n * (L - self.L0) ** 2 + 0.5 * bend

    def energy(self, u, theta) -> float:
        """The live bonds' strain energy."""
        return float(np.sum(self.energies(u, theta)[self.alive]))

    def forces(self, u, theta, m=None):
        """(forces [m, 2], torques [m]) of the live bonds on the particles at
        displacements ``u`` and rotations ``theta`` (``m`` particles; default:
        as many as u).  No bond breaks here: the compiled loop breaks them."""
        L, e1, e2, N, M_i, M_j = self._loads(u, theta)
        N, M_i, M_j = (np.where(self.alive, x, 0.0) for x in (N, M_i, M_j))
        f_j = -N[:, None] * e1 + ((M_i + M_j) / L)[:, None] * e2
        m = len(u) if m is None else m
        force = np.zeros((m, 2))
        for c in range(2):
            force[:, c] = (np.bincount(self.j, f_j[:, c], minlength=m) -
                           np.bincount(self.i, f_j[:, c], minlength=m))
        torque = -(np.bincount(self.i, M_i, minlength=m) + np.bincount(self.j, M_j, minlength=m))
        return force, torque
