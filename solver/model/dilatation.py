"""The volumetric (many-body) term of a bonded packing: Poisson's ratios above
the central-bond network's.

Central bonds obey the Cauchy relation (lambda = mu for an affine network), so
a packing of them has one Poisson's ratio (about 1/3 in plane stress, 1/4 in
3D; :mod:`solver.model.calibration`).  Every particle p also stores the energy

    U_p = 1/2 c_p theta_p^2,   theta_p = (dim / n_p) sum_q s_pq,   s_pq = (|x_q - x_p| - L_pq) / L_pq,

over its n_p live bonds (p, q): theta_p, dim times the mean bond strain of its
star, is the dilatation tr(eps) of a uniform strain (the mean of e.eps.e over
directions is tr(eps) / dim) and is zero for a rigid motion of any size.  For a
uniform strain the term adds c / V to Lame's lambda and nothing to mu, so it
raises nu (towards 1 in plane stress, 1/2 in 3D) without touching the shear
modulus; a measured uniaxial test (:func:`calibration.calibrate_bulk`) finds the
factor eta in c_p = eta kappa E V_p n_p / n_full (V_p = (2 r_p)^2 t in 2D,
(2 r_p)^3 in 3D; n_full = 6 in 2D, 12 in 3D: a particle with fewer bonds, on a
free surface, stands for less volume) that gives the material's nu, and kappa
then its E.  Its force is a tension
along every bond,

    T_pq = (P_p + P_q) / L_pq,   P_p = c_p theta_p dim / n_p = eta kappa E V_p theta_p dim / n_full,

added to the bond's own k (L - L0) (:mod:`solver.partitions.dilatation`).  This is
the volumetric term of André et al. (2013), "Using the discrete element method to
simulate brittle fracture in the indentation of a silica glass with a blunt
indenter", Comput. Methods Appl. Mech. Engrg. 265, with the dilatation from bond
strains (Peridynamics' state-based dilatation on a particle's bond family).

The term acts on the particles of the packing's core and their bonds to each
other; a transition band's particles, whose bonds are linear elements on the
band cells' nodes, keep central bonds alone.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


FULL = {2: 6.0, 3: 12.0}       # bonds of a particle in a dense packing's bulk (the weights' unit)


def volumes(radii, dim: int, depth: float = 1.0) -> np.ndarray:
    """V_p: (2 r)^2 t (2D) or (2 r)^3 (3D)."""
    return (2.0 * radii) ** dim * (depth if dim == 2 else 1.0)


def weights(radii, i, j, dim: int, depth: float = 1.0) -> np.ndarray:
    """c_p / (eta kappa E) of particles with bonds (i, j): V_p n_p / FULL, the
    volume a particle stands for, in proportion to its bonds (one on a free
    surface, with about half a bulk particle's bonds, counts about half; with
    V_p alone a 3:1:1 bar's surface made it 5 % stiffer than the bulk)."""
    return volumes(radii, dim, depth) * counts(i, j, len(radii)) / FULL[dim]


def counts(i, j, n: int) -> np.ndarray:
    """Bonds at each of n particles."""
    return np.bincount(i, minlength=n) + np.bincount(j, minlength=n)


def gradient(x, i, j):
    """The sparse map G (SciPy CSR, [n particles, n dim]) from displacements to
    the linearised dilatations theta = G u of the bonds (i, j) at rest ``x``."""
    from scipy.sparse import coo_matrix   # lazy: scipy loads only for a random packing
    n, dim = x.shape
    d = x[j] - x[i]
    g = d / np.sum(d * d, axis=1)[:, None]          # ds/du_j = e / L
    per = dim / np.maximum(counts(i, j, n), 1)
    rows, cols, vals = [], [], []
    for p, q, sign in ((i, j, 1.0), (j, i, -1.0)):  # the star of p: (p, q)
        w = (sign * per[p])[:, None] * g             # d theta_p / d u_q
        for owner, at in ((p, q), (p, p)):
            rows.append(np.repeat(owner, dim))
            cols.append((at[:, None] * dim + np.arange(dim)).ravel())
            vals.append((w if at is q else -w).ravel())
    return coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(n, n * dim)).tocsr()


@dataclass(frozen=True)
class Dilatation:
    """The term on the model's nodes: c_p per node (0: none) and each node's
    bond count at rest (its star's size)."""

    c: np.ndarray          # [n_nodes]
    n_bonds: np.ndarray    # [n_nodes]

    def blocks(self, points, bi, bj, held) -> list:
        """Block sets (conn [n, 1 + m], c (dim/m)^2 g g^T) of the stars of the
        ``held`` particles whose m bonds are all among (bi, bj), one set per
        star size: the term's stiffness at rest."""
        n = len(self.c)
        here = counts(bi, bj, n)
        inh = np.zeros(n, bool)
        inh[held] = True
        whole = inh & (self.c > 0) & (here == self.n_bonds) & (here > 0)
        ends = np.concatenate([bi, bj])
        other = np.concatenate([bj, bi])
        order = np.argsort(ends, kind="stable")
        ends, other = ends[order], other[order]
        start = np.searchsorted(ends, np.arange(n + 1))
        out = []
        for m in np.unique(here[whole]):
            stars = np.flatnonzero(whole & (here == m))
            nbrs = other[start[stars][:, None] + np.arange(m)]
            out.append((np.concatenate([stars[:, None], nbrs], axis=1),
                        StarStiffness(points, stars, nbrs, self.c[stars])))
        return out


class StarStiffness:
    """Blocks c (dim/m)^2 g g^T of particles' stars (particle, then its m
    neighbours), g = d theta / d u at rest; computed when asked."""

    def __init__(self, points, centre, nbrs, c):
        self.points, self.centre, self.nbrs, self.c = points, centre, nbrs, c

    def __len__(self) -> int:
        return len(self.centre)

    def __getitem__(self, idx) -> np.ndarray:
        p, q, c = self.centre[idx], self.nbrs[idx], self.c[idx]
        d = self.points[q] - self.points[p][:, None, :]                 # [n, m, dim]
        m = q.shape[1]
        dim = d.shape[2]
        w = (dim / m) * d / np.sum(d * d, axis=2)[..., None]
        g = np.concatenate([-w.sum(axis=1, keepdims=True), w], axis=1).reshape(len(p), -1)
        return c[:, None, None] * g[:, :, None] * g[:, None, :]

    def subset(self, mask) -> "StarStiffness":
        return StarStiffness(self.points, self.centre[mask], self.nbrs[mask], self.c[mask])
