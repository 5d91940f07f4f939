"""Contact between lattice particles that are not bonded (``model.lattice.contact``).

Particles are spheres of radius r: two that are closer than 2r and share no
live bond push each other apart with a linear spring,
f = k_n (2r - d) along the line of centres (energy 1/2 k_n (2r - d)^2).  A
pair bonded at rest is never in contact while its bond lives; once the bond
breaks, the two touch again only when pressed closer than 2r, so a crack
that opens transmits nothing and a crack that closes transmits compression.

Candidate pairs come from a k-d tree (scipy's cKDTree) over the particles
within 2r + skin, rebuilt only when some particle has moved more than half
the skin since the last build; the search and its arrays exist only in
scenes with ``model.lattice.contact``.  The stable step accounts for contact
springs with a bound: lambda_max(K_bonds + K_contact) <= lambda_bonds +
2 z k_n / m_min, z the largest coordination of equal spheres (6 in 2D, 12 in
3D).
"""
from __future__ import annotations

import numpy as np


def coordination(dim: int) -> int:
    return 6 if dim == 2 else 12


class Contact:
    """Repulsive contact of the particles ``nodes`` (local indices into the
    position array) with radius ``radius`` and normal stiffness ``kn``."""

    def __init__(self, nodes, radius, kn, skin, bonded_i, bonded_j):
        self.nodes = np.asarray(nodes, dtype=np.int64)
        self.radius, self.kn, self.skin = radius, kn, skin
        n = int(max(self.nodes.max(initial=0), bonded_i.max(initial=0), bonded_j.max(initial=0))) + 1
        self._n = n
        a, b = np.minimum(bonded_i, bonded_j), np.maximum(bonded_i, bonded_j)
        self._bond_key = a * n + b                    # bond b's pair key (local indices)
        self._x_built = None
        self._pairs = np.zeros((0, 2), dtype=np.int64)
        self.builds = 0
        self.energy = 0.0

    def _build(self, x):
        from scipy.spatial import cKDTree
        pts = x[self.nodes]
        pairs = cKDTree(pts).query_pairs(2 * self.radius + self.skin, output_type="ndarray")
        self._pairs = self.nodes[pairs] if len(pairs) else np.zeros((0, 2), dtype=np.int64)
        self._x_built = pts.copy()
        self.builds += 1

    def _touching(self, x, alive, node=None):
        """(i, j, d = x_j - x_i, distance, overlap) of the candidate pairs (of
        ``node`` only, if given) that overlap and share no live bond."""
        i, j = self._pairs[:, 0], self._pairs[:, 1]
        if node is not None:
            at = (i == node) | (j == node)
            i, j = i[at], j[at]
        key = np.minimum(i, j) * self._n + np.maximum(i, j)
        d = x[j] - x[i]
        dist = np.linalg.norm(d, axis=1)
        overlap = 2 * self.radius - dist
        touch = (overlap > 0) & ~np.isin(key, self._bond_key[alive]) & (dist > 0)
        return i[touch], j[touch], d[touch], dist[touch], overlap[touch]

    def stress(self, x, alive, node, c) -> float:
        """sum over the contacts of ``node`` of f_c r_c (its virial, sign of tension):
        a pushing contact has f = -k_n overlap n on the particle and r = dist n."""
        _, _, d, dist, overlap = self._touching(x, alive, node)
        return float(-np.sum((self.kn * overlap / dist) * d[:, c] ** 2))

    def forces(self, x, alive, out, rows):
        """Add the contact forces at positions ``x`` to ``out`` (rows < ``rows``);
        ``alive``: the bonds' live flags (a live bond excludes its pair)."""
        pts = x[self.nodes]
        if self._x_built is None or \
                np.max(np.linalg.norm(pts - self._x_built, axis=1), initial=0.0) > 0.5 * self.skin:
            self._build(x)
        i, j, d, dist, overlap = self._touching(x, alive)
        if not i.size:
            self.energy = 0.0
            return
        f = (self.kn * overlap / dist)[:, None] * d             # on j, away from i
        self.energy = float(0.5 * self.kn * np.sum(overlap ** 2))
        keep_i, keep_j = i < rows, j < rows
        for c in range(out.shape[1]):
            out[:, c] -= np.bincount(i[keep_i], f[keep_i, c], minlength=rows)
            out[:, c] += np.bincount(j[keep_j], f[keep_j, c], minlength=rows)
