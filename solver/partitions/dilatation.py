"""The volumetric term of a bonded packing at run time
(:mod:`solver.model.dilatation` has the law and its calibration).

Per force evaluation, one compiled pass over the bonds
(:func:`solver.partitions.bond_kernel.dilatation_sums`) from their current
lengths L (rest lengths L0, at their temperature): every owned particle's
dilatation theta_p = (dim / n_p) sum_q (L_pq - L0_pq) / L0_pq over its n_p live
bonds (a piece holds every bond of the particles it owns) and P_p = c_p
theta_p dim / n_p; the ghosts' P (particles of another piece) come from their
owners by one VecScatter of a scalar per particle; every bond then pulls with
the tension (P_p + P_q) / L0_pq besides its own spring, which the compiled
bond loop adds.  (The numpy passes this replaced made the Brazilian disc's
stepping 3.8 x slower than without the term.)

A break changes n_p and theta_p of both ends at the same positions: the
energy that drops out counts as released (at the breaking evaluation), and a
change of rest lengths (heat) at fixed positions as thermal work, so the
energy audit still closes.
"""
from __future__ import annotations

import numpy as np

from solver.petscutil import init, vec_on


class Volumetric:
    """The term on the bonds of a :class:`solver.partitions.bonds.BondForce`."""

    def __init__(self, force, c_nodes):
        P = init()
        n0 = force._n_bonded                        # held + bond ghosts
        self.force = force
        self.c = np.asarray(c_nodes, float)[force.ids[:n0]]
        self.n_owned = force.part.layout.n_owned
        self.c[force.n_held:] = 0.0                  # ghosts: their owners' P arrive instead
        self.P = np.zeros(n0)
        self._total = np.zeros(force.n_held)        # (dilatation_sums' sums and counts)
        self._count = np.zeros(force.n_held)
        self._scatter = None
        self._rest = None                           # d / |d|^2 of every bond at rest
        part = force.part
        if part.comm.size > 1 or force.n_ghosts:     # collective: every piece at once
            n_local, n_global = part.u.getSizes()
            dof = force.dim
            self._own = np.zeros(n_local // dof)
            self._vec = vec_on(self._own, part.comm, (n_local // dof, n_global // dof))
            self._g = np.zeros(force.n_ghosts)
            self._g_vec = vec_on(self._g, P.COMM_SELF)
            self._is = P.IS().createGeneral(force._bond_ghosts.astype(P.IntType),
                                            comm=P.COMM_SELF)
            self._scatter = P.Scatter().create(self._vec, self._is, self._g_vec, None)
            self._modes = (P.InsertMode.INSERT_VALUES, P.ScatterMode.FORWARD)

    def _theta(self, L, L0, alive):
        """(theta, live bond count) of the held particles (complete for owned ones)."""
        f = self.force
        n = f.n_held
        s = np.where(alive, (L - L0) / L0, 0.0)
        live = alive.astype(float)
        fi, fj = f._fi, f._fj
        total = (np.bincount(f._ri, s[fi], minlength=n) + np.bincount(f._rj, s[fj], minlength=n))
        count = (np.bincount(f._ri, live[fi], minlength=n) +
                 np.bincount(f._rj, live[fj], minlength=n))
        dim = f.space
        return dim * total / np.maximum(count, 1.0), count

    def energy(self, L, L0=None, alive=None) -> float:
        """sum over the owned particles of 1/2 c theta^2 at bond lengths ``L``."""
        f = self.force
        theta, _ = self._theta(L, f.L0 if L0 is None else L0, f.alive if alive is None else alive)
        m = self.n_owned
        return 0.5 * float(np.dot(self.c[:m], theta[:m] ** 2))

    def pressures(self, u, on_break):
        """P of the held particles at displacements ``u`` and, by one scatter,
        of the ghosts (collective when split), for the bond loop's tensions
        (P_i + P_j) / L0: one compiled pass over the bonds
        (:func:`solver.partitions.bond_kernel.dilatation_sums`).  Bonds beyond
        their critical strain go to ``on_break(which)`` first (which breaks
        them); P is then that of the bonds that stay."""
        f = self.force
        n = f.n_held
        snap = f._dilatation_sums(f.dX, u, f.i, f.j, f.L0, f.alive, f.limit, n, self._total,
                                  self._count, f._snapped, self.c, self.P)
        if snap:
            on_break(f._snapped[:snap].copy())
        self._to_ghosts(self.P)
        return self.P

    def _to_ghosts(self, values):
        """values[held:] = the owners' values[:owned] of the ghost particles
        (one scalar per particle; collective when split, nothing otherwise)."""
        if self._scatter is not None:
            self._own[:] = 0.0
            self._own[:self.n_owned] = values[:self.n_owned]
            self._scatter.scatter(self._vec, self._g_vec, *self._modes)
            values[self.force.n_held:] = self._g

    def release_broken(self, v, out):
        """out += (K_full - K_live) v of the stars at rest: ``out`` holding -K0 v
        (K0 with every particle's whole star, as assembled), it then holds the
        stars over the live bonds, so a broken bond's share of its ends' stars
        no longer damps across the crack.  Per bond (i, j) at rest, g = d / |d|^2:
        the stars' K v puts (P_i + P_j) g on j and minus that on i, P_p = c_p
        (dim / m_p)^2 sum over p's bonds of g . (v_j - v_i), m_p its bond count
        (whole: all, live: the live ones).  Collective when split (the ghosts'
        P, two scatters), every piece at every call (BondForce.release_broken
        calls it once a bond of the partition has broken)."""
        from solver.partitions.bond_kernel import star_rates, star_release  # lazy: numba's, as the force's
        f = self.force
        n = f.n_held
        if self._rest is None:
            self._rest = np.ascontiguousarray(f.dX / np.sum(f.dX * f.dX, axis=1)[:, None])
            self._rates = tuple(np.zeros(len(self.P)) for _ in range(2)) + \
                tuple(np.zeros(n) for _ in range(4))
        whole, live, *scratch = self._rates
        star_rates(self._rest, v, f.i, f.j, f.alive, n, self.c, whole, live, *scratch)
        self._to_ghosts(whole)
        self._to_ghosts(live)
        star_release(self._rest, f.i, f.j, f.alive, whole, live, out, n)

    def last_tensions(self, bonds) -> np.ndarray:
        """The tensions (P_i + P_j) / L0 of ``bonds`` at the last
        :meth:`pressures` (not collective)."""
        f = self.force
        return (self.P[f.i[bonds]] + self.P[f.j[bonds]]) / f.L0[bonds]

    def destroy(self):
        if self._scatter is not None:
            for obj in (self._scatter, self._is, self._g_vec, self._vec):
                obj.destroy()
