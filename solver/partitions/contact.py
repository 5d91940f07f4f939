"""Contact between lattice particles that are not bonded (``model.lattice.contact``).

Particles are spheres of radius r: two that are closer than 2r and share no
live bond push each other apart along the line of centres n, with the
overlap d = 2r - |x_j - x_i| (``radii``, a random packing's spread radii:
r_i + r_j - |x_j - x_i|, so that no pair touches at rest and a bond that
breaks at rest leaves its pair untouched), with the force, tangent and energy of the
settings' law (:data:`solver.laws.CONTACT_LAWS`):
- law linear: f = k_n d (energy 1/2 k_n d^2);
- law hertz:  f = k_h d^1.5 (energy 2/5 k_h d^2.5), tangent 1.5 k_h d^0.5;
- a normal dashpot (``damping_ratio`` zeta) adds c v_approach, c = 2 zeta
  sqrt(k m*) with k the tangent stiffness and m* the pair's reduced mass (a
  spring-dashpot; its dissipation enters the energy audit);
- friction (``friction`` mu), ``friction_model`` viscous: a tangential force
  against the sliding velocity v_t of magnitude min(mu f_n, c_t |v_t|),
  c_t = 2 zeta_t sqrt(k m*): Coulomb's limit with a viscous regularisation
  and no shear history (as LAMMPS's gran/hooke); it only dissipates;
- ``friction_model`` history (Cundall and Strack 1979; LAMMPS's
  gran/hooke/history): each contact keeps its shear displacement xi, the
  tangential part of the change of x_j - x_i since the contact began.  At
  every force evaluation the stored xi is turned into the current tangent
  plane (its length kept), the tangential part of the separation's change
  since the last evaluation is added, and the spring k_t = ratio x k (k the
  normal tangent stiffness) pulls with -k_t xi, capped at mu f_n: beyond
  it the contact slides, xi is shortened to mu f_n / k_t and the spring
  energy the cap takes, 1/2 k_t (|xi|^2 - (mu f_n / k_t)^2) (mu f_n times
  the slip in steady sliding), is dissipated, as is the last 1/2 k_t |xi|^2
  of a contact that opens.  While it sticks a
  dashpot c_t = 2 zeta_t sqrt(k_t m*) acts beside the spring, the two
  together at most mu f_n.  The spring holds 1/2 k_t |xi|^2 (strain energy).
  A pair's xi lives while it touches; it is kept by global particle ids
  across rebuilds of the search and of the halo, so that every piece that
  evaluates the pair holds the same xi (in its own orientation: exactly the
  negative where its local order is the other way), and in checkpoints.
A pair bonded at rest is never in contact while its bond lives; once the bond
breaks, the two touch again only when pressed closer than 2r, so a crack
that opens transmits nothing and a crack that closes transmits compression.

Rotating particles (``rotary``: beam models' rotations, u's last column
(2D) or three (3D, their rate the angular velocity), out's the torques): the contact point
lies half way between the centres, l = |x_j - x_i| / 2 from each; the shear
displacement also grows by -l (dtheta_i + dtheta_j) x n (2D: about z; a
pair turning rigidly with its particles strains nothing), the tangential
force's moment -l n x f_t turns both particles (the two balance the pair's
forces' moment: angular momentum is kept; a moment in the space frame,
as the angular velocity's equation takes it), and with
``rolling_friction`` mu_r a rolling spring k_r = k_t (r/2)^2 on the
relative rotation theta_i - theta_j since the contact began turns them
apart, capped at mu_r (r/2) f_n (3D: on its tangential part, turned with the
contact as the shear spring is and capped in length; twisting about n is
free).

Distances are taken as (X_j - X_i) + (u_j - u_i) from the rest positions X
and the displacements u, as the bonds take theirs (see
:mod:`solver.partitions.bond_kernel`), never from the rounded sums X + u.

Candidate pairs come from a cell list over the particles within 2r + skin
(the compiled search of :mod:`solver.partitions.contact_kernel`; the numpy
reference path asks scipy's cKDTree, which finds the same pairs), rebuilt
only when some particle has moved more than half the skin since the last
build; the search and its arrays exist only in scenes with
``model.lattice.contact``.  On a dem partition split over ranks
the decision to rebuild is taken for all pieces at once, and each piece's
particles then change with its halo (:mod:`solver.partitions.halo`).

The stable step accounts for contact springs with a bound:
lambda_max(K_bonds + K_contact) <= lambda_bonds + 2 z k / m_min, z the
largest coordination of equal spheres (6 in 2D, 12 in 3D), k the law's
bound (hertz: its tangent at an overlap of 0.1 r), times max(1, k_t / k)
with shear springs.
"""
from __future__ import annotations

import numpy as np

# the laws the compiled loops know (solver.partitions.contact_kernel), by name
KERNEL_LAWS = {"linear": 0, "hertz": 1}

# pair keys i * KEY + j of local indices: larger than any piece's position count
KEY = np.int64(1) << 31


def coordination(dim: int) -> int:
    return 6 if dim == 2 else 12


def bound_stiffness(contact, spin=0.0) -> float:
    """The contact stiffness the step bound uses, from the ContactSettings: a
    contact's stiffness k n n^T + k_t (I - n n^T) has the norm max(k, k_t);
    ``spin``: the largest r^2 m / I of rotating particles, whose shear spring
    also turns them (its mass-weighted norm k_t (1/m_i + 1/m_j + l^2/I_i +
    l^2/I_j), l <= r, is at most k_t (1 + spin) (1/m_i + 1/m_j)); a rolling
    spring k_r = k_t r^2 / 4 adds k_r (1/I_i + 1/I_j) <= k_t spin / 4 (1/m_i +
    1/m_j)."""
    k = contact.law.bound(contact.radius)
    if not contact.history:
        return k
    turning = spin * (1.25 if contact.rolling_friction else 1.0)
    return k * max(1.0, contact.tangential_stiffness * (1.0 + turning))


class Contact:
    """Repulsive contact of the particles ``nodes`` (local indices into the
    position array) with the :class:`solver.laws.ContactSettings` ``settings``
    (law, radius, skin, dashpot and friction); ``mass``: each position's
    particle mass (the dashpot).
    Positions below ``owned`` are this piece's own particles: only pairs with
    one of them count here, their energy and dissipation half per owned end
    (on a dem partition split over ranks the others are bond ghosts and the
    halo: :mod:`solver.partitions.halo`).
    ``rest``: the rest positions X of the local positions; the methods then
    take displacements u (without it, X = 0 and they take positions).
    ``decides``: :meth:`forces` rebuilds the search itself when it is stale
    (False: the caller does, for all pieces at once).  ``ids``: the global id
    of each local position (the shear history's keys; default the local
    index); ``dt``: the step, over which :meth:`viscous` spreads the work of
    sliding as a power.  ``compiled``: the loops of
    :mod:`solver.partitions.contact_kernel` (False: numpy over arrays of
    pairs, the reference they are tested against)."""

    def __init__(self, nodes, settings, bonded_i, bonded_j, mass=None, owned=None, rest=None,
                 decides=True, ids=None, dt=None, compiled=True, rotary=False, radii=None):
        self.nodes = np.asarray(nodes, dtype=np.int64)
        self._ordered = bool(np.all(np.diff(self.nodes) > 0))    # pairs keep their order
        self.law = settings.law
        self.radius, self.skin = settings.radius, settings.skin     # (radii: the largest)
        self.radii = None if radii is None else np.asarray(radii, dtype=float)
        self._uniform = None               # the compiled loops' radii without ``radii``
        self.zeta, self.mu = settings.damping_ratio, settings.friction
        self.zeta_t = settings.tangential_damping_ratio
        self.history = settings.history
        self.ratio = settings.tangential_stiffness
        self.rolling = settings.rolling_friction       # mu_r (0: no rolling resistance)
        self.mass = mass
        self.turns = int(rotary)          # u's last columns: rotations (2D 1, 3D 3), out's: torques
        self.ids, self.dt = ids, dt
        self._shear = None                            # (xi, separation, live) per pair of _mine
        self._pending = None                          # a history table for the next build
        self._slipped = 0.0            # the shear springs' dissipation at the last forces [J]
        self.rest = rest
        self.decides = decides
        self.owned = np.iinfo(np.int64).max if owned is None else owned
        a, b = np.minimum(bonded_i, bonded_j), np.maximum(bonded_i, bonded_j)
        key = a * KEY + b                             # bond b's pair key (local indices)
        self._key_order = np.argsort(key, kind="stable")
        self._sorted_keys = key[self._key_order]
        self._u_built = None                          # displacements at the last build
        self._pairs = np.zeros((0, 2), dtype=np.int64)
        self._mine = None                             # the candidates with an owned end
        self._last = None                  # (i, j, n, tangent k, f_n, shear, d) of the last forces
        dim = rest.shape[1] if rest is not None else None
        if self.turns and dim is not None and self.turns != ROTATIONS[dim]:
            raise ValueError(f"contact: rotating particles turn by {ROTATIONS[dim]} "
                             f"rotation(s) in {dim}D, not {self.turns}")
        if self.rolling and not (self.turns and self.history):
            raise ValueError("contact: rolling resistance needs rotating particles and shear "
                             "springs (friction_model history)")
        self._code = KERNEL_LAWS.get(self.law.name) if compiled and dim in (2, 3, None) else None
        self.compiled = self._code is not None
        if self.compiled:      # lazy: numba (about 1 s to import) loads only with contact
            from solver.partitions import contact_kernel
            self._kern = contact_kernel
            self._forces = self._viscous = None       # the loops of the dimension (_allocate)
        self._dim = dim                    # the translations' count (set by build)
        self._eval = None                  # compiled: per candidate pair (see contact_kernel)
        self._fresh = False                # compiled: _last not yet taken from _eval
        self.builds = 0
        self.energy = 0.0

    @property
    def reach(self) -> float:
        """2r + skin: the distance within which a pair is a candidate (r the
        largest radius)."""
        return 2 * self.radius + self.skin

    def _touch_at(self, i, j):
        """The distance r_i + r_j below which pairs (i, j) touch."""
        if self.radii is None:
            return 2 * self.radius
        return self.radii[i] + self.radii[j]

    def _arm(self, i, j):
        """The pairs' effective radius R* = r_i r_j / (r_i + r_j) (r / 2 for equal
        radii): the rolling spring's k_r = k_t R*^2 and cap mu_r R* f_n."""
        if self.radii is None:
            return 0.5 * self.radius
        ri, rj = self.radii[i], self.radii[j]
        return ri * rj / (ri + rj)

    def _radii_of(self, n):
        """Every local position's radius for the compiled loops (n positions)."""
        if self.radii is not None:
            return self.radii
        if self._uniform is None or len(self._uniform) != n:
            self._uniform = np.full(n, float(self.radius))
        return self._uniform

    def _moved(self, u):
        """The translations of ``u`` (without the rotations of rotating particles)."""
        return u[:, :u.shape[1] - self.turns]

    def _points(self, u):
        """The positions X + u of the contact particles."""
        pts = self._moved(u)[self.nodes]
        return pts + self.rest[self.nodes] if self.rest is not None else pts

    def stale(self, u) -> bool:
        """Whether the search must be rebuilt at displacements ``u``: never built,
        or a particle has moved more than half the skin since."""
        if self._u_built is None:
            return True
        u = self._moved(u)
        if self.compiled:
            moved = self._kern.largest_move(u, self.nodes, self._u_built)
        else:
            step = u[self.nodes] - self._u_built
            moved = np.max(np.einsum("pc,pc->p", step, step), initial=0.0)
        return bool(moved > (0.5 * self.skin) ** 2)

    def renew(self, nodes, mass, rest, ids=None, radii=None):
        """New contact particles ``nodes`` (local indices) with the masses, rest
        positions, global ids and radii (with ``radii`` at construction) of
        every local position (a piece's halo changed); the search is then
        built by :meth:`build`, which takes the shear histories over by
        global ids."""
        if self.history:
            self._pending = self.table()
        self.nodes = np.asarray(nodes, dtype=np.int64)
        self._ordered = bool(np.all(np.diff(self.nodes) > 0))
        self.mass, self.rest = mass, rest
        if radii is not None:
            self.radii = np.asarray(radii, dtype=float)
        if ids is not None:
            self.ids = ids
        self._u_built = None

    def build(self, u):
        """The candidate pairs at displacements ``u``, and those with an owned
        end with their bonds and rest separations (what every step reads)."""
        if self.compiled:                  # a cell list: pairs come sorted
            pairs = self._kern.pairs_within(self._points(u), self.reach)
        else:
            from scipy.spatial import cKDTree  # lazy: scipy loads only where it is used
            pairs = cKDTree(self._points(u)).query_pairs(self.reach, output_type="ndarray")
        pairs = self.nodes[pairs] if len(pairs) else np.zeros((0, 2), dtype=np.int64)
        # by first particle, then second: the loops then read the positions in order
        if not self._ordered or not self.compiled:
            pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]
        self._pairs = pairs
        # each candidate pair's bond (-1: none), found once per build
        i, j = pairs[:, 0], pairs[:, 1]
        if len(self._sorted_keys):
            key = np.minimum(i, j) * KEY + np.maximum(i, j)
            at = np.minimum(np.searchsorted(self._sorted_keys, key), len(self._sorted_keys) - 1)
            found = self._sorted_keys[at] == key
            self._pair_bond = np.where(found, self._key_order[at], -1)
        else:
            self._pair_bond = np.full(len(i), -1, dtype=np.int64)
        # the histories move to the new pairs in one merge of local pair keys
        # (compiled, numbering unchanged), else by global ids
        before = self._mine
        merge = self.history and self.compiled and self._pending is None and before is not None
        table = self.table() if self.history and not merge else None
        self._mine = self._subset((i < self.owned) | (j < self.owned))
        if merge:
            self._shear = self._kern.carry(before[0], before[1], *self._shear, i, j)
        dim = self._dim = u.shape[1] - self.turns
        if not merge and self.history:
            self._take_over(table, dim)
        self._pending = None
        if self.compiled:
            self._allocate(dim)
        self._u_built = self._moved(u)[self.nodes].copy()
        self.builds += 1

    def _allocate(self, dim):
        """The compiled loops' arrays for the pairs with an owned end; with
        shear springs the separations are the histories' (the loop advances
        them; rotating particles: and the pair's sum and difference of
        rotations)."""
        i, j, bond, with_bond, rest = self._mine
        m = i.size
        self._forces, self._viscous = self._kern.LOOPS[dim]        # (2D and 3D only)
        none = np.zeros((0, dim))
        width = dim + 2 * self.turns
        xi, d, live = self._shear if self.history else (none, np.zeros((m, width)),
                                                        np.zeros(0, bool))
        self._eval = dict(pi=np.ascontiguousarray(i), pj=np.ascontiguousarray(j),
                          bond=np.ascontiguousarray(bond) if with_bond.size else
                          np.zeros(0, np.int64),
                          rest=np.ascontiguousarray(rest) if rest is not None else none,
                          xi=xi, live=live, d=d, touch=np.zeros(m, bool), dist=np.ones(m),
                          sticks=np.zeros(m, bool))

    def _evaluated(self):
        """(i, j, n, k, f_n, shear, d) of the pairs touching at the last
        :meth:`forces` (None: none), taken from the compiled loop's arrays
        when it ran."""
        if self._fresh:
            e = self._eval
            at = np.flatnonzero(e["touch"])
            self._fresh = False
            self._last = None
            if at.size:
                d, dist = e["d"][at, :self._dim], e["dist"][at]
                f, k, _ = self.law.evaluate(self._touch_at(e["pi"][at], e["pj"][at]) - dist)
                shear = ((-self.ratio * k)[:, None] * e["xi"][at, :self._dim], e["sticks"][at]) \
                    if self.history else None
                self._last = (e["pi"][at], e["pj"][at], d / dist[:, None], k, f, shear, d)
        return self._last

    def _global(self, i, j):
        """Pair keys min * KEY + max of the global ids of local pairs (i, j), and
        each pair's orientation (-1 where the global order is j, i)."""
        gi, gj = (i, j) if self.ids is None else (self.ids[i], self.ids[j])
        sign = np.where(gi < gj, 1.0, -1.0)
        return np.minimum(gi, gj) * KEY + np.maximum(gi, gj), sign

    def table(self):
        """The shear history of the touching pairs as (sorted global keys, xi,
        separation at the last evaluation), each oriented from the smaller
        global id to the larger; empty where no pair touches."""
        if self._pending is not None:                 # taken over at the next build
            return self._pending
        if self._shear is None:
            return np.zeros(0, np.int64), np.zeros((0, 0)), np.zeros((0, 0))
        xi, sep, live = self._shear
        at = np.flatnonzero(live)
        keys, sign = self._global(self._mine[0][at], self._mine[1][at])
        order = np.argsort(keys)
        return keys[order], xi[at][order] * sign[order, None], self._oriented(sep[at][order],
                                                                           sign[order])

    def _oriented(self, sep, sign):
        """Separations ``sep`` turned to orientations ``sign`` (+-1 per pair); a
        rotating pair's sum of rotations (the columns after the separation) is
        the same either way, their difference (the last) changes sign."""
        flip = np.repeat(sign[:, None], sep.shape[1], axis=1)
        flip[:, self._dim:self._dim + self.turns] = 1.0
        return sep * flip

    def restore(self, keys, xi, sep):
        """Shear histories of a checkpoint (global keys, xi and separations
        oriented from the smaller id): taken at the next force evaluation,
        which rebuilds the search."""
        order = np.argsort(keys)
        self._pending = (np.asarray(keys, np.int64)[order], xi[order], sep[order])
        self._u_built = None

    def _take_over(self, table, dim):
        """The new candidate pairs' histories from ``table`` (by global ids)."""
        keys, xi, sep = table
        i, j = self._mine[0], self._mine[1]
        new_xi = np.zeros((i.size, dim + self.turns))
        new_sep = np.zeros((i.size, dim + 2 * self.turns))
        live = np.zeros(i.size, bool)
        if keys.size and i.size:
            mine, sign = self._global(i, j)
            at = np.minimum(np.searchsorted(keys, mine), keys.size - 1)
            live = keys[at] == mine
            new_xi[live] = xi[at[live]] * sign[live, None]
            new_sep[live] = self._oriented(sep[at[live]], sign[live])
        self._shear = (new_xi, new_sep, live)

    def _spring(self, at, d, unit, k, fn, turns=None):
        """The shear springs of the touching pairs ``at`` (indices into the
        pairs with an owned end) at separations ``d`` (rotating particles:
        ``turns``, each pair's sum and difference of rotations): their force
        on j, their energy, whether each sticks, the work of sliding (this
        piece's share) and the rolling springs' moments on j (None without);
        the histories advance to this evaluation."""
        xi_all, sep_all, live_all = self._shear
        was = live_all[at]
        xi = np.where(was[:, None], xi_all[at], 0.0)
        now = d if turns is None else np.column_stack([d, *turns])
        step = np.where(was[:, None], now - sep_all[at], 0.0)
        dim = d.shape[1]
        T, phi = self.turns, None
        if turns is not None:          # the contact point rolls by -l (dtheta_i + dtheta_j) x n
            # (3D: about the mid separation, second order in the step; in 2D the
            # difference is along n)
            roll = -0.5 * _spin(step[:, dim:dim + T], d if T == 1 else d - 0.5 * step[:, :dim])
            if self.rolling and T == 1:
                phi = xi[:, dim] + step[:, dim + T]
            elif self.rolling:         # 3D: turned into the tangent plane, plus the
                phi = _turn_in(xi[:, dim:], unit, step[:, dim + T:])   # relative turn's part
            step, xi = step[:, :dim] + roll, xi[:, :dim]
        xi = _turn_in(xi, unit, step)
        kt = self.ratio * k
        length = np.linalg.norm(xi, axis=1)
        cap = self.mu * fn
        slides = kt * length > cap
        shrink = np.where(slides, cap / np.where(slides, kt * length, 1.0), 1.0)
        lost = 0.5 * kt * length ** 2 * (1.0 - shrink ** 2)     # what the cap takes
        xi *= shrink[:, None]
        held = 0.5 * kt * np.einsum("pc,pc->p", xi, xi)
        moment = None
        if phi is not None:            # the rolling spring k_r = k_t R*^2, at most mu_r R* f_n
            arm = self._arm(self._mine[0][at], self._mine[1][at])
            kr = arm ** 2 * kt
            most = self.rolling * arm * fn / np.where(kr > 0, kr, 1.0)
            if T == 1:
                kept = np.clip(phi, -most, most)
                size2, kept2 = phi ** 2, kept ** 2
                moment = kr * kept
            else:                      # 3D: its length capped, its direction kept
                size = np.linalg.norm(phi, axis=1)
                kept = phi * np.where(size > most, most / np.where(size > 0, size, 1.0),
                                      1.0)[:, None]
                size2, kept2 = size ** 2, np.minimum(size, most) ** 2
                moment = kr[:, None] * kept
            lost = lost + 0.5 * kr * (size2 - kept2)
            held = held + 0.5 * kr * kept2
            xi = np.column_stack([xi, kept])
        elif turns is not None:        # (no rolling spring: its columns stay zero)
            xi = np.column_stack([xi, np.zeros((len(at), T))])
        live_all[:] = False
        live_all[at] = True
        xi_all[at], sep_all[at] = xi, now
        return -kt[:, None] * xi[:, :dim], held, ~slides, lost, moment

    def _let_go(self, at):
        """The last spring energy of the pairs that touched at the last
        evaluation and do not now (``at``: those that do), this piece's share."""
        xi_all, sep_all, live_all = self._shear
        gone = live_all.copy()
        gone[at] = False
        gone = np.flatnonzero(gone)
        if not gone.size:
            return 0.0
        i, j = self._mine[0][gone], self._mine[1][gone]
        overlap = self._touch_at(i, j) - np.linalg.norm(sep_all[gone, :self._dim], axis=1)
        _, k, _ = self.law.evaluate(np.maximum(overlap, 0.0))
        xi = xi_all[gone].copy()
        xi[:, self._dim:] *= np.reshape(self._arm(i, j), (-1, 1))   # rolling: k_r = k_t R*^2
        held = 0.5 * self.ratio * k * np.einsum("pc,pc->p", xi, xi)
        return float(np.dot(held, self._share(self._mine[0][gone], self._mine[1][gone])))

    def _subset(self, at):
        """(i, j, bond, which of them have a bond, rest separations X_j - X_i or
        None) of the candidate pairs ``at`` (a mask)."""
        i, j, bond = self._pairs[at, 0], self._pairs[at, 1], self._pair_bond[at]
        rest = self.rest[j] - self.rest[i] if self.rest is not None else None
        return i, j, bond, np.flatnonzero(bond >= 0), rest

    def _touching(self, u, alive, node=None):
        """(i, j, d = x_j - x_i, distance, overlap, where) at displacements ``u``
        of the candidate pairs (of ``node`` only, if given) that overlap and
        share no live bond; ``where``: their indices among the candidates."""
        if node is None:                                     # the pairs with an owned end
            i, j, bond, with_bond, rest = self._mine
        else:
            i, j, bond, with_bond, rest = self._subset((self._pairs == node).any(axis=1))
        moved = self._moved(u)
        d = moved[j] - moved[i]
        if rest is not None:
            d += rest
        dist = np.linalg.norm(d, axis=1)
        overlap = self._touch_at(i, j) - dist
        bonded = np.zeros(len(i), bool)
        bonded[with_bond] = alive[bond[with_bond]]           # a live bond excludes the pair
        touch = np.flatnonzero((overlap > 0) & ~bonded & (dist > 0))
        return i[touch], j[touch], d[touch], dist[touch], overlap[touch], touch

    def _share(self, i, j):
        """Each pair's share here: half per owned end."""
        return 0.5 * ((i < self.owned).astype(float) + (j < self.owned).astype(float))

    def stress(self, u, alive, node, c) -> float:
        """sum over the contacts of ``node`` of f_c r_c (its virial, sign of tension):
        a pushing contact has f = -f_n n on the particle and r = dist n; the
        shear springs count with their forces of the last :meth:`forces`."""
        _, _, d, dist, overlap, _ = self._touching(u, alive, node)
        f, _, _ = self.law.evaluate(overlap)
        total = float(-np.sum((f / dist) * d[:, c] ** 2))
        last = self._evaluated()
        if last is not None and last[5] is not None:
            i, j, _, _, _, (spring, _), d = last
            at = (i == node) | (j == node)
            total -= float(np.sum(spring[at, c] * d[at, c]))
        return total

    def forces(self, u, alive, out, rows):
        """Add the contact forces at displacements ``u`` to ``out`` (rows <
        ``rows``); ``alive``: the bonds' live flags (a live bond excludes its pair)."""
        if self.decides and self.stale(u):
            self.build(u)
        if self.compiled:
            e = self._eval
            self.energy, self._slipped = self._forces(
                e["pi"], e["pj"], e["bond"], alive, e["rest"], u, self._radii_of(len(u)),
                self._code,
                self.law.stiffness, self.history, self.ratio, self.mu, e["xi"], e["live"],
                e["touch"], e["d"], e["dist"], e["sticks"], out, rows, self.owned, self.turns,
                self.rolling)
            self._fresh = True
            return
        i, j, d, dist, overlap, at = self._touching(u, alive)
        let_go = self._let_go(at) if self.history and self._shear is not None else 0.0
        if not i.size:
            self.energy, self._last, self._slipped = 0.0, None, let_go
            if self._shear is not None:
                self._shear[2][:] = False                    # no pair touches: no history
            return
        f, k, energy = self.law.evaluate(overlap)
        unit = d / dist[:, None]
        force = f[:, None] * unit
        share = self._share(i, j)
        shear = None
        if self.history:
            T = u.shape[1] - self.turns
            turns = (u[i, T:] + u[j, T:], u[i, T:] - u[j, T:]) if self.turns else None
            spring, held, sticks, slipped, moment = self._spring(at, d, unit, k, f, turns)
            force += spring
            energy = energy + held
            self._slipped = float(np.dot(slipped, share)) + let_go
            shear = (spring, sticks)
            if self.turns:
                self._torques(out, rows, i, j, d, spring)
            if self.rolling:
                moment = moment.reshape(len(i), -1)
                first = out.shape[1] - moment.shape[1]
                for end, sign in ((i, -1.0), (j, 1.0)):      # the rolling springs' moments
                    keep = end < rows
                    for c in range(moment.shape[1]):
                        out[:, first + c] += sign * np.bincount(end[keep], moment[keep, c],
                                                                minlength=rows)
        self.energy = float(np.dot(energy, share))
        self._last = (i, j, unit, k, f, shear, d)
        _scatter(out, rows, i, j, force)

    @staticmethod
    def _torques(out, rows, i, j, d, f):
        """Add the moment -l n x f of tangential forces ``f`` on j (l = |d| / 2,
        the contact point half way) to both particles' torques (out's last
        column in 2D, last three in 3D)."""
        if d.shape[1] == 2:
            torque = -0.5 * (d[:, :1] * f[:, 1:] - d[:, 1:] * f[:, :1])
        else:
            torque = -0.5 * np.cross(d, f)
        first = out.shape[1] - torque.shape[1]
        for end in (i, j):
            keep = end < rows
            for c in range(torque.shape[1]):
                out[:, first + c] += np.bincount(end[keep], torque[keep, c], minlength=rows)

    def touching(self):
        """(i, j) local indices of the pairs in contact at the last :meth:`forces`."""
        last = self._evaluated()
        if last is None:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        return last[0], last[1]

    @property
    def dissipative(self) -> bool:
        return bool(self.zeta or self.mu)

    def viscous(self, v, out, rows) -> float:
        """Add the dashpot and friction forces of the contacts of the last
        :meth:`forces` at velocities ``v`` to ``out``; returns their dissipated
        power [W] (this piece's share)."""
        if not self.dissipative:
            return 0.0
        slipped = self._slipped / self.dt if self._slipped else 0.0   # the springs', as a power
        if self.history and not (self.zeta or self.zeta_t):      # springs without dashpots
            return slipped
        if self.compiled:
            e = self._eval
            return slipped + self._viscous(
                e["pi"], e["pj"], e["touch"], e["d"], e["dist"], self._radii_of(len(v)),
                self._code,
                self.law.stiffness, self.history, e["xi"], e["sticks"], self.mass, v, self.zeta,
                self.mu, self.zeta_t, self.ratio, out, rows, self.owned, self.turns)
        if self._last is None:
            return slipped
        i, j, unit, k, fn, shear, d_last = self._last
        mi, mj = self.mass[i], self.mass[j]
        root = np.sqrt(k * mi * mj / (mi + mj))
        moved = self._moved(v)
        dv = moved[j] - moved[i]
        vn = np.einsum("pc,pc->p", dv, unit)                    # separation rate
        force = np.zeros_like(dv)                               # on j
        power = np.zeros(len(i))
        if self.zeta:
            c = 2 * self.zeta * root
            force -= (c * vn)[:, None] * unit
            power += c * vn ** 2
        if self.mu:
            vt = dv - vn[:, None] * unit                         # sliding velocity of j on i
            if self.turns:                       # the spins' part -l (w_i + w_j) x n
                T = v.shape[1] - self.turns
                vt -= 0.5 * _spin(v[i, T:] + v[j, T:], d_last)
            speed = np.linalg.norm(vt, axis=1)
            if shear is None:
                ft = np.minimum(self.mu * fn, 2 * self.zeta_t * root * speed)
            else:                              # beside a sticking spring, together <= mu f_n
                spring, sticks = shear
                room = np.maximum(self.mu * fn - np.linalg.norm(spring, axis=1), 0.0)
                ft = np.where(sticks, np.minimum(
                    room, 2 * self.zeta_t * np.sqrt(self.ratio) * root * speed), 0.0)
            slide = speed > 0
            friction = np.zeros_like(vt)
            friction[slide] = -(ft[slide] / speed[slide])[:, None] * vt[slide]
            force += friction
            power += ft * speed
            if self.turns:
                self._torques(out, rows, i, j, d_last, friction)
        _scatter(out, rows, i, j, force)
        return slipped + float(np.dot(power, self._share(i, j)))


ROTATIONS = {2: 1, 3: 3}      # a rotating particle's rotations: about z; about x, y, z


def _turn_in(x, unit, add):
    """Vectors ``x`` [n, dim] turned into the planes normal to ``unit`` [n, dim],
    their lengths kept, plus the parts of ``add`` in those planes (a spring
    that turns with its contact and grows by the change)."""
    length = np.linalg.norm(x, axis=1)
    x = x - np.einsum("pc,pc->p", x, unit)[:, None] * unit
    turned = np.linalg.norm(x, axis=1)
    x *= np.divide(length, turned, out=np.zeros_like(length), where=turned > 0)[:, None]
    return x + add - np.einsum("pc,pc->p", add, unit)[:, None] * unit


def _spin(w, d):
    """w x d of spins ``w`` ([n] or [n, 1] about z in 2D, [n, 3]) and vectors ``d`` [n, dim]."""
    if d.shape[1] == 2:
        w = w.reshape(-1)
        return np.column_stack([-w * d[:, 1], w * d[:, 0]])
    return np.cross(w, d)


def _scatter(out, rows, i, j, f):
    """out[j] += f, out[i] -= f for rows < ``rows`` (f on j, away from i)."""
    keep_i, keep_j = i < rows, j < rows
    for c in range(f.shape[1]):
        out[:, c] -= np.bincount(i[keep_i], f[keep_i, c], minlength=rows)
        out[:, c] += np.bincount(j[keep_j], f[keep_j, c], minlength=rows)
