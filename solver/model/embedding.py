"""Particles inside coarse cells: Zhang et al.'s (2009) transition-zone transfer (eq. 3-5).

A particle of the transition band sits inside one FE cell; ``locate`` finds
that cell and the particle's local coordinates xi (inverse isoparametric map,
Newton's method; one step for the linear simplices), so every particle carries
the shape-function weights N_i(xi) of its cell's nodes.  With them:

- forces go to the nodes (eq. 3): f_node = sum over its particles of N_i f_p;
- velocities (and displacement increments) come back (eq. 4):
  v_p = sum_i N_i v_i;
- masses match (eq. 5): m_node = sum over its particles of N_i m_p, so the
  band's density is the lattice's.

Because the weights are a partition of unity and reproduce linear fields
(sum_i N_i X_i = x_p), the transfer conserves total force, moment, mass and
momentum, and carries rigid-body motions exactly (tests/test_embedding.py).
Pure numpy; :mod:`solver.model.transition` builds the transition zone on it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from solver.errors import SceneError
from solver.model.elements import FAMILIES

INSIDE_TOL = 1e-9          # reference-coordinate slack on cell faces
NEWTON_STEPS = 20
BOX_TESTS = 2 * 10**7      # particle x cell x dim comparisons per chunk (bounds the temporaries)


@dataclass(frozen=True)
class Embedding:
    """Where every particle sits: its cell, the cell's nodes and the weights."""

    cell: np.ndarray        # [n_p] index of the containing cell (in the ``conn`` given)
    nodes: np.ndarray       # [n_p, k] node ids of that cell
    weights: np.ndarray     # [n_p, k] N_i(xi) at the particle
    xi: np.ndarray          # [n_p, dim] local coordinates

    def to_nodes(self, values: np.ndarray, n_nodes: int) -> np.ndarray:
        """Per-particle values [n_p, ...] gathered to nodes with the weights
        (forces, eq. 3; masses, eq. 5): [n_nodes, ...]."""
        values = np.asarray(values, dtype=float)
        flat = values.reshape(len(values), -1)
        out = np.zeros((n_nodes, flat.shape[1]))
        w = self.weights[:, :, None] * flat[:, None, :]
        np.add.at(out, self.nodes.ravel(), w.reshape(-1, flat.shape[1]))
        return out.reshape((n_nodes,) + values.shape[1:])

    def to_particles(self, values: np.ndarray) -> np.ndarray:
        """Nodal values [n_nodes, ...] interpolated at the particles (velocities
        and displacement increments, eq. 4): [n_p, ...]."""
        values = np.asarray(values, dtype=float)
        return np.einsum("pk,pk...->p...", self.weights, values[self.nodes])


def inside(family: str, xi: np.ndarray, tol: float = INSIDE_TOL) -> np.ndarray:
    """Whether local coordinates ``xi`` [n, dim] lie in the reference cell."""
    if FAMILIES[family].simplex:
        return np.all(xi >= -tol, axis=1) & (xi.sum(axis=1) <= 1 + tol)
    return np.all(np.abs(xi) <= 1 + tol, axis=1)


def local_coordinates(family: str, X: np.ndarray, x: np.ndarray) -> np.ndarray:
    """xi [n, dim] with sum_i N_i(xi) X[:, i] = x for cells X [n, k, dim]."""
    fam = FAMILIES[family]
    dim = fam.dim
    xi = np.full((len(x), dim), 0.25) if fam.simplex else np.zeros((len(x), dim))
    for _ in range(NEWTON_STEPS):
        N, dN = fam.shape(xi)
        r = np.einsum("nk,nkd->nd", N, X) - x
        J = np.einsum("nkd,nke->nde", X, dN)               # dx/dxi
        try:
            step = np.linalg.solve(J, r[..., None])[..., 0]
        except np.linalg.LinAlgError:                   # a candidate far outside a distorted cell
            step = np.einsum("nde,ne->nd", np.linalg.pinv(J), r)
        xi = xi - step
        if np.abs(step).max(initial=0.0) < 1e-14:
            break
    return xi


def find(points: np.ndarray, conn: np.ndarray, family: str, particles: np.ndarray):
    """(cell [n_p], xi [n_p, dim]) of every particle in the cells ``conn`` (node
    ids into ``points``), cell -1 for a particle in none.  A particle on a
    shared face goes to the lowest-numbered cell."""
    points = np.asarray(points, dtype=float)
    particles = np.asarray(particles, dtype=float)
    X = points[conn]                                        # [n_c, k, dim]
    lo, hi = X.min(axis=1), X.max(axis=1)
    pad = 1e-9 * max(float(np.ptp(points, axis=0).max(initial=0.0)), 1.0)
    cell = np.full(len(particles), -1, dtype=np.int64)
    xi_all = np.zeros((len(particles), X.shape[2]))
    chunk = max(1, BOX_TESTS // max(1, X.shape[0] * X.shape[2]))
    for s in range(0, len(particles), chunk):
        p = particles[s:s + chunk]
        box = np.all((p[:, None, :] >= lo[None] - pad) & (p[:, None, :] <= hi[None] + pad), axis=2)
        pi, ci = np.nonzero(box)                            # candidate (particle, cell) pairs
        if not pi.size:
            continue
        xi = local_coordinates(family, X[ci], p[pi])
        ok = inside(family, xi)
        pi, ci, xi = pi[ok], ci[ok], xi[ok]
        order = np.lexsort((ci, pi))                        # lowest cell first per particle
        pi, ci, xi = pi[order], ci[order], xi[order]
        first = np.concatenate([[True], pi[1:] != pi[:-1]]) if pi.size else pi.astype(bool)
        cell[s + pi[first]] = ci[first]
        xi_all[s + pi[first]] = xi[first]
    return cell, xi_all


def locate(points: np.ndarray, conn: np.ndarray, family: str, particles: np.ndarray,
           where: str = "particles") -> Embedding:
    """The cell of ``conn`` (node ids into ``points``) holding each particle.
    A particle on a shared face goes to the lowest-numbered cell; a particle in
    no cell is refused, naming it."""
    particles = np.asarray(particles, dtype=float)
    cell, xi = find(points, conn, family, particles)
    lost = np.flatnonzero(cell < 0)
    if lost.size:
        raise SceneError(f"{where}: particle {int(lost[0])} at {particles[lost[0]].tolist()} lies "
                         f"in no cell of the band ({lost.size} such particles)")
    return embedding(conn, family, cell, xi)


def embedding(conn, family, cell, xi) -> Embedding:
    """The Embedding of particles in cells ``cell`` of ``conn`` at local ``xi``."""
    N, _ = FAMILIES[family].shape(xi)
    return Embedding(cell, conn[cell], N, xi)


def flat_cells(cells: dict):
    """All cells of ``cells`` as (family per cell, conn padded with the first node)."""
    k = max(c.shape[1] for c in cells.values())
    fams, conns = [], []
    for fam, conn in cells.items():
        fams += [fam] * len(conn)
        conns.append(np.hstack([conn, np.repeat(conn[:, :1], k - conn.shape[1], axis=1)]))
    return fams, np.concatenate(conns)


def locate_in_cells(points, cells: dict, sites):
    """(cell index over the concatenated families, weights [n, k_max]) of every
    site; cell -1 where none holds it."""
    k = max(c.shape[1] for c in cells.values())
    cell = np.full(len(sites), -1, dtype=np.int64)
    weights = np.zeros((len(sites), k))
    offset = 0
    for fam, conn in cells.items():
        todo = np.flatnonzero(cell < 0)
        c, xi = find(points, conn, fam, sites[todo])
        hit = c >= 0
        if hit.any():
            emb = embedding(conn, fam, c[hit], xi[hit])
            cell[todo[hit]] = offset + c[hit]
            weights[todo[hit], :conn.shape[1]] = emb.weights
        offset += len(conn)
    return cell, weights
