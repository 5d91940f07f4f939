"""Contact between lattice particles that are not bonded (``model.lattice.contact``).

Particles are spheres of radius r: two that are closer than 2r and share no
live bond push each other apart along the line of centres n, with the
overlap d = 2r - |x_j - x_i|, with the force, tangent and energy of the
settings' law (:data:`solver.laws.CONTACT_LAWS`):
- law linear: f = k_n d (energy 1/2 k_n d^2);
- law hertz:  f = k_h d^1.5 (energy 2/5 k_h d^2.5), tangent 1.5 k_h d^0.5;
- a normal dashpot (``damping_ratio`` zeta) adds c v_approach, c = 2 zeta
  sqrt(k m*) with k the tangent stiffness and m* the pair's reduced mass (a
  spring-dashpot; its dissipation enters the energy audit);
- friction (``friction`` mu): a tangential force against the sliding
  velocity v_t of magnitude min(mu f_n, c_t |v_t|), c_t = 2 zeta_t sqrt(k m*):
  Coulomb's limit with a viscous regularisation and no shear history (as
  LAMMPS's gran/hooke); it only dissipates.
A pair bonded at rest is never in contact while its bond lives; once the bond
breaks, the two touch again only when pressed closer than 2r, so a crack
that opens transmits nothing and a crack that closes transmits compression.

Distances are taken as (X_j - X_i) + (u_j - u_i) from the rest positions X
and the displacements u, as the bonds take theirs (see
:mod:`solver.partitions.bond_kernel`), never from the rounded sums X + u.

Candidate pairs come from a k-d tree (scipy's cKDTree) over the particles
within 2r + skin, rebuilt only when some particle has moved more than half
the skin since the last build; the search and its arrays exist only in
scenes with ``model.lattice.contact``.  On a dem partition split over ranks
the decision to rebuild is taken for all pieces at once, and each piece's
particles then change with its halo (:mod:`solver.partitions.halo`).

The stable step accounts for contact springs with a bound:
lambda_max(K_bonds + K_contact) <= lambda_bonds + 2 z k / m_min, z the
largest coordination of equal spheres (6 in 2D, 12 in 3D), k the law's
bound (hertz: its tangent at an overlap of 0.1 r).
"""
from __future__ import annotations

import numpy as np

# pair keys i * KEY + j of local indices: larger than any piece's position count
KEY = np.int64(1) << 31


def coordination(dim: int) -> int:
    return 6 if dim == 2 else 12


def bound_stiffness(contact) -> float:
    """The contact stiffness the step bound uses, from the ContactSettings."""
    return contact.law.bound(contact.radius)


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
    ``decides``: :meth:`forces` rebuilds the tree itself when it is stale
    (False: the caller does, for all pieces at once)."""

    def __init__(self, nodes, settings, bonded_i, bonded_j, mass=None, owned=None, rest=None,
                 decides=True):
        self.nodes = np.asarray(nodes, dtype=np.int64)
        self.law = settings.law
        self.radius, self.skin = settings.radius, settings.skin
        self.zeta, self.mu = settings.damping_ratio, settings.friction
        self.zeta_t = settings.tangential_damping_ratio
        self.mass = mass
        self.rest = rest
        self.decides = decides
        self.owned = np.iinfo(np.int64).max if owned is None else owned
        a, b = np.minimum(bonded_i, bonded_j), np.maximum(bonded_i, bonded_j)
        key = a * KEY + b                             # bond b's pair key (local indices)
        self._key_order = np.argsort(key, kind="stable")
        self._sorted_keys = key[self._key_order]
        self._u_built = None                          # displacements at the last build
        self._pairs = np.zeros((0, 2), dtype=np.int64)
        self._last = None                             # (i, j, n, tangent k) of the last forces
        self.builds = 0
        self.energy = 0.0

    @property
    def reach(self) -> float:
        """2r + skin: the distance within which a pair is a candidate."""
        return 2 * self.radius + self.skin

    def _points(self, u):
        """The positions X + u of the contact particles."""
        pts = u[self.nodes]
        return pts + self.rest[self.nodes] if self.rest is not None else pts

    def stale(self, u) -> bool:
        """Whether the tree must be rebuilt at displacements ``u``: never built,
        or a particle has moved more than half the skin since."""
        if self._u_built is None:
            return True
        moved = np.max(np.linalg.norm(u[self.nodes] - self._u_built, axis=1), initial=0.0)
        return bool(moved > 0.5 * self.skin)

    def renew(self, nodes, mass, rest):
        """New contact particles ``nodes`` (local indices) with the masses and
        rest positions of every local position (a piece's halo changed); the
        tree is then built by :meth:`build`."""
        self.nodes = np.asarray(nodes, dtype=np.int64)
        self.mass, self.rest = mass, rest
        self._u_built = None

    def build(self, u):
        """The candidate pairs at displacements ``u``, and those with an owned
        end with their bonds and rest separations (what every step reads)."""
        from scipy.spatial import cKDTree  # lazy: scipy loads only where it is used
        pairs = cKDTree(self._points(u)).query_pairs(self.reach, output_type="ndarray")
        self._pairs = self.nodes[pairs] if len(pairs) else np.zeros((0, 2), dtype=np.int64)
        # each candidate pair's bond (-1: none), found once per build
        i, j = self._pairs[:, 0], self._pairs[:, 1]
        key = np.minimum(i, j) * KEY + np.maximum(i, j)
        at = np.minimum(np.searchsorted(self._sorted_keys, key), max(len(self._sorted_keys) - 1, 0))
        found = self._sorted_keys[at] == key if len(self._sorted_keys) else np.zeros(len(key), bool)
        self._pair_bond = np.where(found, self._key_order[at] if len(self._key_order) else -1, -1)
        self._mine = self._subset((i < self.owned) | (j < self.owned))
        self._u_built = u[self.nodes].copy()
        self.builds += 1

    def _subset(self, at):
        """(i, j, bond, which of them have a bond, rest separations X_j - X_i or
        None) of the candidate pairs ``at`` (a mask)."""
        i, j, bond = self._pairs[at, 0], self._pairs[at, 1], self._pair_bond[at]
        rest = self.rest[j] - self.rest[i] if self.rest is not None else None
        return i, j, bond, np.flatnonzero(bond >= 0), rest

    def _touching(self, u, alive, node=None):
        """(i, j, d = x_j - x_i, distance, overlap) at displacements ``u`` of the
        candidate pairs (of ``node`` only, if given) that overlap and share no
        live bond."""
        if node is None:                                     # the pairs with an owned end
            i, j, bond, with_bond, rest = self._mine
        else:
            i, j, bond, with_bond, rest = self._subset((self._pairs == node).any(axis=1))
        d = u[j] - u[i]
        if rest is not None:
            d += rest
        dist = np.linalg.norm(d, axis=1)
        overlap = 2 * self.radius - dist
        bonded = np.zeros(len(i), bool)
        bonded[with_bond] = alive[bond[with_bond]]           # a live bond excludes the pair
        touch = (overlap > 0) & ~bonded & (dist > 0)
        return i[touch], j[touch], d[touch], dist[touch], overlap[touch]

    def _share(self, i, j):
        """Each pair's share here: half per owned end."""
        return 0.5 * ((i < self.owned).astype(float) + (j < self.owned).astype(float))

    def stress(self, u, alive, node, c) -> float:
        """sum over the contacts of ``node`` of f_c r_c (its virial, sign of tension):
        a pushing contact has f = -f_n n on the particle and r = dist n."""
        _, _, d, dist, overlap = self._touching(u, alive, node)
        f, _, _ = self.law.evaluate(overlap)
        return float(-np.sum((f / dist) * d[:, c] ** 2))

    def forces(self, u, alive, out, rows):
        """Add the contact forces at displacements ``u`` to ``out`` (rows <
        ``rows``); ``alive``: the bonds' live flags (a live bond excludes its pair)."""
        if self.decides and self.stale(u):
            self.build(u)
        i, j, d, dist, overlap = self._touching(u, alive)
        if not i.size:
            self.energy, self._last = 0.0, None
            return
        f, k, energy = self.law.evaluate(overlap)
        self.energy = float(np.dot(energy, self._share(i, j)))
        unit = d / dist[:, None]
        self._last = (i, j, unit, k, f)
        _scatter(out, rows, i, j, f[:, None] * unit)

    def touching(self):
        """(i, j) local indices of the pairs in contact at the last :meth:`forces`."""
        if self._last is None:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        return self._last[0], self._last[1]

    @property
    def dissipative(self) -> bool:
        return bool(self.zeta or self.mu)

    def viscous(self, v, out, rows) -> float:
        """Add the dashpot and friction forces of the contacts of the last
        :meth:`forces` at velocities ``v`` to ``out``; returns their dissipated
        power [W] (this piece's share)."""
        if self._last is None or not self.dissipative:
            return 0.0
        i, j, unit, k, fn = self._last
        mi, mj = self.mass[i], self.mass[j]
        root = np.sqrt(k * mi * mj / (mi + mj))
        dv = v[j] - v[i]
        vn = np.einsum("pc,pc->p", dv, unit)                    # separation rate
        force = np.zeros_like(dv)                               # on j
        power = np.zeros(len(i))
        if self.zeta:
            c = 2 * self.zeta * root
            force -= (c * vn)[:, None] * unit
            power += c * vn ** 2
        if self.mu:
            vt = dv - vn[:, None] * unit                         # sliding velocity of j on i
            speed = np.linalg.norm(vt, axis=1)
            ft = np.minimum(self.mu * fn, 2 * self.zeta_t * root * speed)
            slide = speed > 0
            force[slide] -= (ft[slide] / speed[slide])[:, None] * vt[slide]
            power += ft * speed
        _scatter(out, rows, i, j, force)
        return float(np.dot(power, self._share(i, j)))


def _scatter(out, rows, i, j, f):
    """out[j] += f, out[i] -= f for rows < ``rows`` (f on j, away from i)."""
    keep_i, keep_j = i < rows, j < rows
    for c in range(out.shape[1]):
        out[:, c] -= np.bincount(i[keep_i], f[keep_i, c], minlength=rows)
        out[:, c] += np.bincount(j[keep_j], f[keep_j, c], minlength=rows)
