"""Bonds from the current configuration, and their breakage
(``model.lattice.geometry: nonlinear``, ``model.lattice.break_strain``).

A bond (i, j) of stiffness k and rest length L0 pulls with
f = k (L - L0) d / L along its current direction d = x_j - x_i, L = |d|, so a
rigid rotation of a bonded block, however large, exerts no force (the small-
strain operator of :mod:`solver.partitions.force` does not have this
property; for small strains the two agree to first order).  A bond whose
strain (L - L0) / L0 exceeds its critical strain breaks for good: it is
recorded (time, midpoint, strain, critical strain, temperature, particles) and
the energy 1/2 k (L - L0)^2 it held counts as released, so kinetic + strain +
released = external work.  With ``model.lattice.weibull_modulus`` each bond's
critical strain is ``break_strain`` times its Weibull factor
(:mod:`solver.model.strength`, a function of its particles' ids and the seed).
The energy a broken bond releases is the mean of what it held at the force
evaluation that found it broken and at the one before: the integrator's
last kick from it was that earlier force, which passed on half the energy
the bond lost between the two (counting the later energy alone over-counts
by about 7 % of the released energy, and the audit's error is first order in
the step; the mean makes it second order).

With ``heat`` (:mod:`solver.model.heat`) a bond at temperature T (the mean of
its ends') rests at L0 (1 + alpha (T - T0)), and with ``heat.melting`` its
critical strain falls linearly from ``break_strain`` at T0 to zero at Tm.  A
change of rest length at fixed positions changes the strain energy; that
change counts as thermal work (the energy audit's external work includes it).

Elements that are not lattice bonds (overlap cells, bonds carried to a
transition band's nodes) stay linear: one MatMult with their operator.
Particles of another piece of the same partition (the partition split over
ranks) are ghosts, refreshed by one VecScatter per force evaluation: the
other ends of this piece's bonds and, with contact, its halo
(:mod:`solver.partitions.halo`), the particles near its own ones, which
changes when the contact search is rebuilt.  All pieces that hold a bond
evaluate it from the same positions, so they agree on when it breaks.  Numpy
on arrays of bonds: no per-bond Python loop.
"""
from __future__ import annotations

import numpy as np

from solver.model import strength
from solver.petscutil import init, vec_on
from solver.partitions.contact import KEY, Contact
from solver.partitions.dilatation import Volumetric
from solver.partitions.force import Force
from solver.partitions.halo import ContactHalo


class BondForce(Force):
    """f_int(u) of a dem partition with geometrically nonlinear, breakable bonds."""

    linear = False
    bonded = True

    def __init__(self, part, lattice_block, linear_op, other_blocks, tangent, break_strain,
                 contact=None, heat=None, node_mass=None, weibull=None, dilatation=None):
        # lazy: numba (about 1 s to import) loads only when a bonded partition is built
        from solver.partitions.bond_kernel import bond_forces, dilatation_sums, rest_length_work
        self._bond_forces, self._rest_length_work = bond_forces, rest_length_work
        self._dilatation_sums = dilatation_sums
        P = init()
        self.part = part
        self._any_broken = False           # whether a bond of the partition has broken
        self.operator = linear_op            # the other elements' -K (None if there are none)
        self.blocks = other_blocks
        self._tangent = tangent              # -K of everything at rest (stability, damping)
        self.break_strain = break_strain
        dim = part.dof
        self.dim = dim
        conn, stiff = lattice_block
        lay = part.layout
        held = lay.held
        whole = np.unique(conn)              # the lattice particles this share of the model has
        # bonds with at least one owned end: this piece's rows
        local = lay.local(conn.ravel()).reshape(conn.shape)
        mine = ((local >= 0) & (local < lay.n_owned)).any(axis=1)
        source = np.flatnonzero(mine)            # each bond's block in ``stiff``
        conn, k, local = conn[mine], stiff.k[mine], local[mine]
        # bonds sorted by their first local particle: the compiled loop sums a run once
        ghost_last = np.where(local < 0, np.iinfo(np.int64).max, local)
        order = np.lexsort((ghost_last[:, 1], ghost_last[:, 0]))
        conn, k, local = conn[order], k[order], local[order]
        self._rest_blocks, self._source = stiff, source[order]    # (release_broken)
        self._gone_blocks = (np.zeros(0, np.int64), None)   # the broken bonds' blocks
        ghosts = np.unique(conn[local < 0])                  # another piece's particles
        at = np.searchsorted(ghosts, conn)
        local = np.where(local < 0, held.size + at, local)  # ghosts after the held nodes
        self.i, self.j = local[:, 0], local[:, 1]
        self.n_ghosts = ghosts.size
        self.k = k
        self.nodes = conn
        points = stiff.points
        self.X = np.concatenate([points[held], points[ghosts]]) if ghosts.size else points[held]
        self.ids = np.concatenate([held, ghosts])     # global id of every local position
        self.dX = self.X[self.j] - self.X[self.i]    # rest separations (see bond_kernel)
        self.L0 = np.linalg.norm(self.dX, axis=1)        # rest lengths (at the bond's temperature)
        self.L_cold = self.L0.copy()                 # ... at T0
        # critical strain per bond (infinite: unbreakable)
        self.limit = np.full(len(k), np.inf if break_strain is None else break_strain)
        if weibull is not None and break_strain is not None:      # the strengths' spread
            self.limit = break_strain * strength.weibull(conn[:, 0], conn[:, 1], *weibull)
        self._strength = self.limit.copy()               # (thermal weakening scales it)
        self.heat = heat.spec if heat is not None else None
        self.T = None                                # per-bond temperature (with heat)
        self._shares = None
        self.alive = np.ones(len(k), bool)
        self.n_held = held.size
        self.broken = []                     # (t, midpoint..., strain, node i, node j)
        self.released = 0.0                  # energy of the broken bonds [J]
        self.now = 0.0
        self._ghost = self._gv = None
        self._modes = (P.InsertMode.INSERT_VALUES, P.ScatterMode.FORWARD)
        self._bond_ghosts = part.dist.number[ghosts]     # their partition numbers
        self._n_bonded = held.size + ghosts.size         # local positions before the halo
        if part.comm.size > 1 or ghosts.size:
            self._scatter(self._bond_ghosts)
        # each bond's rows kept here: only held rows (ghost rows belong to other pieces)
        self._fi = self.i < self.n_held
        self._fj = self.j < self.n_held
        self._ri, self._rj = self.i[self._fi], self.j[self._fj]
        self.space = self.X.shape[1]               # (rotating particles: dim = space + 1)
        self._u = np.zeros((len(self.X), dim))     # displacements of held + ghost particles
        self._snapped = np.zeros(len(k), dtype=np.int64)
        self._u_last = None                        # held + bond ghosts at the last evaluation
        self.volumetric = None                     # the volumetric term (dilatation)
        if dilatation is not None:
            self.volumetric = Volumetric(self, dilatation.c)
        self.contact = self.halo = None
        if contact is not None:
            self._start_contact(contact, part, whole, node_mass)
        if self.contact is None or not self.contact.dissipative:
            self.viscous = None                  # the partition then makes no call per step

    def _start_contact(self, settings, part, whole, node_mass):
        """Contact of the lattice particles this piece holds and of its bond
        ghosts; split over ranks, also of its halo, built here at the
        current displacements (collective).  Particles of another partition
        (the lattice sites an overlap gives the fem side, held here as
        external copies) take no part: the fem side would never feel their
        reaction, and the overlap's cells already join them to the dem
        particles."""
        lay, held = part.layout, part.layout.held
        loc = lay.local(whole)
        particles = np.concatenate([loc[loc >= 0], held.size + np.arange(self.n_ghosts)])
        particles = particles[~np.isin(self.ids[particles], part.dist.external)]
        mass = node_mass[self.ids]
        split = part.comm.size > 1
        self._bonded_contact = (particles, mass)
        self.contact_settings = settings
        self.contact = Contact(particles, settings, self.i, self.j, mass, lay.n_owned,
                               rest=self.X, decides=not split, ids=self.ids, dt=part.dt,
                               rotary=self.dim - self.space, radii=self._radii(settings))
        if split:
            mine = particles[particles < held.size]
            self.halo = ContactHalo(part.comm, self.contact.reach, mine[mine < lay.n_owned],
                                    mine, held[mine], lay.start + mine, self.X[mine], mass[mine],
                                    self.ids)
            self._rehalo(part.u)

    def _radii(self, settings):
        """Every local position's contact radius (None: one for all)."""
        return None if settings.radii is None else settings.radii[self.ids]

    def _scatter(self, numbers):
        """The ghost scatter of the particles of partition numbers ``numbers``
        (collective: every piece of the partition creates its own at once)."""
        P, dim = init(), self.dim
        if self._ghost is not None:
            for obj in (self._ghost, self._is, self._g_vec, *(self._gv or ())[1:]):
                obj.destroy()
            self._gv = None
        idx = (numbers[:, None] * dim + np.arange(dim)).ravel().astype(P.IntType)
        self._g_arr = np.zeros(idx.size)
        self._g_vec = vec_on(self._g_arr, P.COMM_SELF)
        self._is = P.IS().createGeneral(idx, comm=P.COMM_SELF)
        self._ghost = P.Scatter().create(self.part.u, self._is, self._g_vec, None)

    def _rehalo(self, u_vec, u=None):
        """Collective: the halo at displacements ``u_vec`` (``u``: their local
        values, if known), its ghost scatter and the contact search with it;
        returns the new local displacements."""
        n, n0 = self.n_held, self._n_bonded
        if u is None:
            u = self.displacements(u_vec)
        ids, numbers, rest, mass = self.halo.select(self.X[:n] + u[:n, :self.space])
        self._scatter(np.concatenate([self._bond_ghosts, numbers]))
        self.X = np.concatenate([self.X[:n0], rest])
        self.ids = np.concatenate([self.ids[:n0], ids])
        self._u = np.zeros((len(self.X), self.dim))
        particles, bonded_mass = self._bonded_contact
        self.contact.renew(np.concatenate([particles, n0 + np.arange(ids.size)]),
                           np.concatenate([bonded_mass, mass]), self.X, self.ids,
                           self._radii(self.contact_settings))
        u = self.displacements(u_vec)
        self.contact.build(u)
        return u

    def _add_contact(self, u_vec, u, out):
        """Add the contact forces at displacements ``u_vec`` (``u``: their local
        values) to ``out``; split over ranks, the halo first follows a
        rebuild of the search (collective)."""
        if self.halo is not None and self.halo.stale(self.contact.stale(u)):
            u = self._rehalo(u_vec, u)
        self.contact.forces(u, self.alive, out, self.n_held)

    @property
    def n_halo(self) -> int:
        """Particles of the halo (0 unless contact on a partition split over ranks)."""
        return self.ids.size - self._n_bonded

    def contact_pairs(self):
        """The global ids (i < j) of the pairs in contact at the last force
        evaluation that this piece counts: those whose end of smaller id is
        owned here, or owned by no piece of the partition and the other end
        is owned here (summed over the pieces: each pair once)."""
        i, j = self.contact.touching()
        gi, gj = self.ids[i], self.ids[j]
        a, b = np.minimum(gi, gj), np.maximum(gi, gj)
        counted = self._counted(a, b)
        return np.stack([a[counted], b[counted]], axis=1)

    def _counted(self, a, b):
        """Which pairs of global ids a < b this piece counts (see
        :meth:`contact_pairs`), by global ids alone: the pairs need not be
        among the particles it holds now."""
        owned = np.sort(self.ids[:self.part.layout.n_owned])
        a_here, b_here = np.isin(a, owned), np.isin(b, owned)
        a_owned = ~np.isin(a, self.part.dist.external)      # (every contact particle is held)
        return a_here | (~a_owned & b_here)

    def contact_history(self):
        """The shear histories this piece counts, rows (a, b, xi [, rolling
        rotation phi], separation [, sum and difference of the rotations])
        oriented from the smaller global id a to b (a checkpoint's), or None
        without them.  Right after a restore, before
        the search is built again, they are the restored rows this piece
        counts."""
        if self.contact is None or not self.contact.history:
            return None
        keys, xi, sep = self.contact.table()
        a, b = keys // KEY, keys % KEY
        counted = self._counted(a, b)
        return np.column_stack([a, b, xi.reshape(a.size, self.dim),
                                sep.reshape(a.size, self.dim + self.dim - self.space)])[counted]

    def restore_contacts(self, rows):
        """Shear histories of a checkpoint (rows of :meth:`contact_history`, all
        pieces'); they apply from the next force evaluation."""
        if self.contact is None or not self.contact.history:
            return
        turning = self.dim - self.space                 # rotating particles: 1
        rows = np.asarray(rows, dtype=float).reshape(-1, 2 + 2 * self.dim + turning)
        a, b = rows[:, 0].astype(np.int64), rows[:, 1].astype(np.int64)
        dim = self.dim
        self.contact.restore(a * KEY + b, rows[:, 2:2 + dim], rows[:, 2 + dim:])

    # ---------------------------------------------------------------- state
    def bonds_at(self, node) -> np.ndarray:
        """The bonds (indices) that end at local node ``node``."""
        return np.flatnonzero((self.i == node) | (self.j == node))

    def displacements(self, u_vec):
        """Displacements of the held and ghost particles (refreshing the ghosts:
        collective), in a buffer the next call overwrites."""
        u, n = self._u, self.n_held
        u[:n] = u_vec.getArray(readonly=True).reshape(n, self.dim)
        if self._ghost is not None:
            self._ghost.scatter(u_vec, self._g_vec, *self._modes)
            u[n:] = self._g_arr.reshape(-1, self.dim)
        return u

    def separations(self, u, bonds=slice(None)):
        """x_j - x_i of ``bonds`` at displacements ``u`` (of :meth:`displacements`),
        as dX + (u_j - u_i): no round-off of X + u (see bond_kernel)."""
        return self.dX[bonds] + (u[self.j[bonds]] - u[self.i[bonds]])

    def virial(self, u, bonds, c) -> float:
        """sum f_c d_c over ``bonds`` at displacements ``u`` (of
        :meth:`displacements`): f = (k (L - L0) + T) d / L, live bonds only, T
        the volumetric term's tension at the last force evaluation (0 without)."""
        d = self.separations(u, bonds)
        L = np.linalg.norm(d, axis=1)
        tension = 0.0
        if self.volumetric is not None:      # of the last force evaluation (no scatter here)
            tension = self.volumetric.last_tensions(bonds)
        pull = np.where(self.alive[bonds], (self.k[bonds] * (L - self.L0[bonds]) + tension) /
                        np.where(L > 0, L, 1.0), 0.0)
        return float(np.sum(pull * d[:, c] ** 2))

    def _bonds(self, u_vec):
        u = self.displacements(u_vec)
        d = self.separations(u)
        L = np.linalg.norm(d, axis=1)
        return u, d, L

    def internal(self, u_vec, out_vec):
        """out = f_int(u); bonds beyond their critical strain break first (at
        ``now``).  The compiled loop (:mod:`solver.partitions.bond_kernel`)."""
        u, n = self.displacements(u_vec), self.n_held
        if self.operator is not None:
            self.operator.mult(u_vec, out_vec)
        out = out_vec.getArray().reshape(n, self.dim)
        P = self._pressures(u) if self.volumetric is not None else None
        snapped = self._bond_forces(self.dX, u, self.i, self.j, self.k, self.L0, self.alive,
                                    self.limit, out, n, self._snapped, self.operator is not None,
                                    P)
        if snapped:
            which = self._snapped[:snapped].copy()
            self._break(which, u, np.linalg.norm(self.separations(u, which), axis=1)
                        - self.L0[which])
        self._remember(u)
        if self.contact is not None:
            self._add_contact(u_vec, u, out)

    def _pressures(self, u):
        """The volumetric term's P at displacements ``u``; the bonds beyond
        their critical strain break first, the term's energy they take with
        them counted as released (collective when split)."""
        def on_break(which):
            L = np.linalg.norm(self.separations(u), axis=1)
            stretch = L[which] - self.L0[which]
            self._release_volumetric(L, u, lambda: self._break(which, u, stretch))
        return self.volumetric.pressures(u, on_break)

    def _release_volumetric(self, L, u, brk):
        """Break bonds by calling ``brk``; the volumetric energy the breaks take
        at bond lengths ``L`` (displacements ``u``) counts as released, the mean
        of it there and at the last evaluation's displacements, as for the
        bonds' own energy (:meth:`_released`)."""
        vol = self.volumetric
        was = self.alive.copy()
        lengths = [L]
        if self._u_last is not None:
            lengths.append(np.linalg.norm(self.separations(self._u_last), axis=1))
        before = [vol.energy(x, alive=was) for x in lengths]
        brk()
        taken = [b - vol.energy(x) for b, x in zip(before, lengths)]
        self.released += float(np.mean(taken))

    def release_broken(self, v_vec, out_vec):
        """out += K_b v of the broken bonds (K_b each one's stiffness at rest):
        ``out`` holding -K0 v (the tangent at rest times the velocities, what
        stiffness-proportional damping takes), it then holds what the live
        bonds and the other elements give, so that a crack's faces are not
        damped as if still bonded; with the volumetric term its stars too
        (:meth:`Volumetric.release_broken`).  Collective on a partition split
        over ranks (the ghosts' velocities), every piece at once; until a bond
        has broken on some piece, it does nothing but ask the pieces so (one
        small allreduce)."""
        if not self._any_broken:           # (once a bond has broken, for good)
            mine, comm = int(not self.alive.all()), self.part.comm
            self._any_broken = bool(comm.allreduce(mine) if comm.size > 1 else mine)
            if not self._any_broken:
                return
        v = self._velocities(v_vec)
        if self.volumetric is not None:         # (collective: before any piece returns)
            self.volumetric.release_broken(v, out_vec.getArray().reshape(self.n_held, self.dim))
        gone = np.flatnonzero(~self.alive)
        if not gone.size:
            return
        cached, Ke = self._gone_blocks
        if not np.array_equal(cached, gone):     # blocks only when bonds have broken since
            Ke = self._rest_blocks[self._source[gone]]          # [b, 2 dof, 2 dof]
            self._gone_blocks = (gone, Ke)
        dof, n = self.dim, self.n_held
        ends = np.stack([self.i[gone], self.j[gone]], axis=1)
        f = np.einsum("bpq,bq->bp", Ke, v[ends].reshape(len(gone), -1)).reshape(-1, 2, dof)
        out = out_vec.getArray().reshape(n, dof)
        for e in range(2):
            keep = ends[:, e] < n
            np.add.at(out, ends[keep, e], f[keep, e])

    def _velocities(self, v_vec):
        """Velocities of the held and ghost particles [local positions, dof]
        (collective when split: the ghosts', like their displacements)."""
        v = v_vec.getArray(readonly=True)
        if self._ghost is not None:
            if self._gv is None:
                self._gv = (np.zeros(self._g_arr.size),)
                self._gv += (vec_on(self._gv[0], init().COMM_SELF),)
            self._ghost.scatter(v_vec, self._gv[1], *self._modes)
            v = np.concatenate([v, self._gv[0]])
        return v.reshape(-1, self.dim)

    def viscous(self, v_vec, out_vec) -> float:
        """Add the contacts' dashpot and friction forces at velocities ``v_vec``
        (contacts of the last :meth:`internal`); returns their dissipated power."""
        n = self.n_held
        return self.contact.viscous(self._velocities(v_vec),
                                    out_vec.getArray().reshape(n, self.dim), n)

    def reference_internal(self, u_vec, out_vec):
        """The same force in numpy (gather, multiply, bincount): the reference
        the compiled loop is tested and benchmarked against."""
        u, d, L = self._bonds(u_vec)
        stretch = L - self.L0
        if self.break_strain is not None:
            snap = self.alive & (stretch > self.limit * self.L0)
            if snap.any():
                which = np.flatnonzero(snap)
                if self.volumetric is not None:
                    self._release_volumetric(L, u, lambda: self._break(which, u, stretch[which]))
                else:
                    self._break(which, u, stretch[which])
        self._remember(u)
        pull = self.k * stretch
        if self.volumetric is not None:
            P = self.volumetric.pressures(u, lambda which: None)   # (broken above)
            pull = pull + (P[self.i] + P[self.j]) / self.L0
        scale = np.where(self.alive, pull / np.where(L > 0, L, 1.0), 0.0)
        f = scale[:, None] * d                                     # force on i (towards j)
        n, dim = self.n_held, self.dim
        out = np.empty((n, dim))
        for c in range(dim):                                       # bincount: no add.at
            out[:, c] = (np.bincount(self._ri, f[self._fi, c], minlength=n) -
                         np.bincount(self._rj, f[self._fj, c], minlength=n))
        if self.contact is not None:
            self._add_contact(u_vec, u, out)
        if self.operator is not None:
            self.operator.mult(u_vec, out_vec)
            out_vec.getArray()[:] += out.ravel()
        else:
            out_vec.getArray()[:] = out.ravel()

    def resume(self, part):
        """After a restore: the restored displacements stand for the last
        evaluation's (the uninterrupted run evaluated the force there last), so
        a bond breaking at the first evaluation releases the same mean energy
        as without the restart, and the volumetric term's P (what stress
        probes read before the next evaluation) is that of the restored state
        (collective: the ghosts' displacements and P)."""
        u = self.displacements(part.u)
        self._remember(u)
        if self.volumetric is not None:
            self.volumetric.pressures(u, lambda which: None)   # (breaks: at the next evaluation)

    def _remember(self, u):
        """Keep the bonded particles' displacements ``u`` of this evaluation
        (the next break's earlier state)."""
        n0 = self._n_bonded
        if self._u_last is None:
            self._u_last = np.empty((n0, self.dim))
        self._u_last[:] = u[:n0]

    def _released(self, now, before):
        """The energy bonds release that held ``now`` at this evaluation and
        what ``before(u)`` gives at the last one's displacements: their mean
        (``now`` before any evaluation)."""
        if self._u_last is None:
            return now
        return 0.5 * (now + before(self._u_last))

    def _break(self, which, u, stretch):
        """Record bonds ``which`` as broken at displacements ``u`` (their
        stretches L - L0: ``stretch``)."""
        self.alive[which] = False
        i, j = self.i[which], self.j[which]
        mid = 0.5 * ((self.X[i] + self.X[j]) + (u[i] + u[j]))
        strain = stretch / self.L0[which]
        limit = self.limit[which]
        temp = self.T[which] if self.T is not None else np.full(which.size, np.nan)
        # the energy is counted once: by the piece that owns the bond's first node
        first = self.i[which] < self.part.layout.n_owned
        k, L0 = self.k[which], self.L0[which]
        held = self._released(0.5 * k * stretch ** 2, lambda v: 0.5 * k * (np.linalg.norm(
            self.separations(v, which), axis=1) - L0) ** 2)
        self.released += float(held[first].sum())
        for w, m, s, c, T, own in zip(which.tolist(), mid, strain, limit, temp, first):
            if own:
                self.broken.append((self.now, *m.tolist(), float(s), float(c), float(T),
                                    int(self.nodes[w, 0]), int(self.nodes[w, 1])))

    def set_temperature(self, T_node, count=True) -> float:
        """Bond temperatures from the model nodes' ``T_node``: rest lengths and
        critical strains follow; returns the thermal work (the change of this
        piece's strain energy at the current positions), 0 unless ``count``."""
        spec = self.heat
        T = 0.5 * (T_node[self.nodes[:, 0]] + T_node[self.nodes[:, 1]])
        L0 = self.L_cold * (1.0 + spec.expansion * (T - spec.initial))
        work = 0.0
        if count and spec.expansion:
            if self._shares is None:
                self._shares = self._share()
            u = self.displacements(self.part.u)
            work = self._rest_length_work(self.dX, u, self.i, self.j,
                                          self.k, self.L0, L0, self.alive, self._shares)
            if self.volumetric is not None:
                L = np.linalg.norm(self.separations(u), axis=1)
                work += self.volumetric.energy(L, L0) - self.volumetric.energy(L)
        self.T, self.L0 = T, L0
        if self.break_strain is not None and spec.melting is not None:
            weak = np.clip((spec.melting - T) / (spec.melting - spec.initial), 0.0, 1.0)
            self.limit = self._strength * weak
        return work

    def _share(self):
        """Each bond's share in this piece's energy: half per owned end."""
        owned = self.part.layout.n_owned
        return 0.5 * ((self.i < owned).astype(float) + (self.j < owned).astype(float))

    def restore_broken(self, rows):
        """Bonds broken before a checkpoint (rows as recorded, any rank layout):
        broken again here, their record and released energy on the piece that
        owns their first particle."""
        rows = np.asarray(rows, dtype=float).reshape(-1, 6 + self.dim) if len(rows) else \
            np.zeros((0, 6 + self.dim))
        pairs = {(int(a), int(b)) for a, b in rows[:, -2:].astype(np.int64).tolist()}
        key = list(zip(self.nodes[:, 0].tolist(), self.nodes[:, 1].tolist()))
        self.alive = np.array([pair not in pairs for pair in key], dtype=bool)
        owned = set(self.part.layout.owned.tolist())
        mine = [r for r in rows.tolist() if int(r[-2]) in owned]
        self.broken = [tuple(r[:-2]) + (int(r[-2]), int(r[-1])) for r in mine]
        at = {pair: b for b, pair in enumerate(key)}
        spec = self.heat
        released = 0.0
        for r in mine:                       # r: t, midpoint, strain, limit, T, i, j
            b = at[(int(r[-2]), int(r[-1]))]
            L0 = self.L_cold[b]
            if spec is not None and np.isfinite(r[-3]):
                L0 *= 1.0 + spec.expansion * (r[-3] - spec.initial)
            released += 0.5 * self.k[b] * (r[-5] * L0) ** 2
        self.released = float(released)

    def damage(self) -> np.ndarray:
        """Fraction of its lattice bonds each owned particle has lost [n_owned]."""
        n = self.part.layout.n_owned
        ends = np.concatenate([self.i, self.j])
        lost = np.concatenate([~self.alive, ~self.alive]).astype(float)
        mine = ends < n
        total = np.bincount(ends[mine], minlength=n)
        gone = np.bincount(ends[mine], lost[mine], minlength=n)
        return np.where(total > 0, gone / np.maximum(total, 1), 0.0)

    def tangent(self):
        """dF/du at rest: the small-strain operator (stability bounds, damping)."""
        return self._tangent

    def energy(self, part) -> float:
        """Strain energy of the live bonds, half to each end this piece owns,
        plus the other elements' (owned rows)."""
        _, _, L = self._bonds(part.u)
        e = np.where(self.alive, 0.5 * self.k * (L - self.L0) ** 2, 0.0)
        total = float(np.dot(e, self._share()))
        if self.volumetric is not None:
            total += self.volumetric.energy(L)
        if self.contact is not None:             # of the last force evaluation (one piece)
            total += self.contact.energy
        if self.operator is not None:
            n = part.n_energy
            self.operator.mult(part.u, part.r)
            total -= 0.5 * float(np.dot(part.U[:n], part.R[:n]))
        return total

    def destroy(self):
        for obj in (self.operator, self._tangent, self.volumetric):
            if obj is not None:
                obj.destroy()
        if self._ghost is not None:
            for obj in (self._ghost, self._is, self._g_vec, *(self._gv or ())[1:]):
                obj.destroy()
