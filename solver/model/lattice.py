"""Bonded DEM lattices: a square lattice with diagonal bonds (2D) and a simple
cubic lattice with face-diagonal bonds (3D).

Calibration (central linear bonds, spacing a, thickness t): every lattice cell
contributes k1/2 to each of its four edge bonds and k2 to each of its two
diagonals, and a quarter of rho t a^2 to each corner particle.  The cell energy
gives C11 = (k1 + k2)/t, C12 = C66 = k2/t (plane stress), so the lattice is
isotropic for k1 = 2 k2, with

    plane stress:  nu = 1/3,  E = 8 k2 / (3 t),  so k2 = 3 E t / 8
    plane strain:  nu = 1/4 (in-plane nu' = nu / (1 - nu) = 1/3), and with
                   E' = E / (1 - nu^2) per unit thickness, k2 = 3 E' / 8

3D (simple cubic with face diagonals): every cube cell contributes k/4 to each
of its 12 edges and k/2 to each of its 12 face diagonals, and rho a^3 / 8 to
each corner; C11 = (k_e + 2 k_d)/a, C12 = C44 = k_d/a, isotropic for
k_e = k_d = k, with nu = 1/4 and E = 2.5 k / a, so k = 0.4 E a.

A central-force lattice cannot represent other Poisson ratios (Cauchy
relation): ``calibrate`` refuses |nu - nu_lattice| > NU_TOLERANCE and reports
the difference otherwise.  Boundary particles and bonds get the shares of the
cells that exist, so masses and stiffness match bilinear quadrilaterals of the
same grid at the surface.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

NU_TOLERANCE = 0.02


@dataclass(frozen=True)
class Lattice:
    points: np.ndarray       # [n, dim]
    mass: np.ndarray         # [n]
    spacing: float
    corners: np.ndarray      # [n_cells, 2^dim] particles of each lattice cell
    shape: tuple             # particles per axis
    contributions: tuple     # (corner offset a, corner offset b, k): every cell's share of bond a-b

    def bonds(self, keep=None, order: bool = True):
        """The bonds of the cells ``keep`` (a mask over the cells; None: all),
        each cell's contributions summed: (i, j, k) with i < j, by (i, j)
        (``order`` False: by direction, for a caller that renumbers and sorts).

        The sum runs over the site grid one bond direction at a time (a
        bond's contributions come from cells of one direction, all of the
        same k, so any order of summing gives the same bits), never over a
        list of every cell's contributions: a 3D model's set-up peaked on
        that list and its sort."""
        shape = tuple(int(x) for x in self.shape)
        cells = tuple(x - 1 for x in shape)
        kept = np.ones(cells) if keep is None else np.asarray(keep, float).reshape(cells)
        start = {}                       # direction d -> k of the bond from each site p to p + d
        for a, b, k in self.contributions:
            d = tuple(int(y) - int(x) for x, y in zip(a, b))
            grid = start.setdefault(d, np.zeros(shape))
            # cell c's contribution is to the bond from site c + a
            grid[tuple(slice(x, x + n) for x, n in zip(a, cells))] += k * kept
        n = np.int64(len(self.points))
        total = sum(int(np.count_nonzero(grid)) for grid in start.values())
        i, j, k = np.empty(total, np.int64), np.empty(total, np.int64), np.empty(total)
        at = 0                           # filled in place: no list of pieces to concatenate
        for d in list(start):
            grid = start.pop(d)
            p = np.flatnonzero(grid)
            q = np.ravel_multi_index(tuple(np.array(np.unravel_index(p, shape)) +
                                           np.array(d)[:, None]), shape)
            end = at + p.size
            np.minimum(p, q, out=i[at:end])
            np.maximum(p, q, out=j[at:end])
            k[at:end] = grid.ravel()[p]
            at = end
            del grid, p, q
        if not order:
            return i, j, k
        by = np.argsort(i * n + j)
        return i[by], j[by], k[by]

    @cached_property
    def _merged(self):
        return self.bonds()

    @property
    def bond_i(self) -> np.ndarray:
        """The bonds of all cells (made when first asked)."""
        return self._merged[0]

    @property
    def bond_j(self) -> np.ndarray:
        return self._merged[1]

    @property
    def stiffness(self) -> np.ndarray:
        """k per bond [N/m]."""
        return self._merged[2]


def calibrate(E: float, nu: float, length: float, kind: str) -> tuple[float, float, float]:
    """(edge k, diagonal k, lattice nu).  ``length``: the thickness in plane
    stress, the spacing for a 3D (solid) lattice, unused in plane strain."""
    if kind == "plane_stress":
        nu_lat, k2 = 1 / 3, 3 * E * length / 8
        k1, name = 2 * k2, "a square lattice with diagonal bonds"
    elif kind == "plane_strain":
        nu_lat, k2 = 1 / 4, 3 * (E / (1 - nu ** 2)) / 8
        k1, name = 2 * k2, "a square lattice with diagonal bonds"
    else:
        nu_lat, k2 = 1 / 4, 0.4 * E * length
        k1, name = k2, "a simple cubic lattice with face-diagonal bonds"
    if abs(nu - nu_lat) > NU_TOLERANCE:
        raise ValueError(f"{name} represents nu = {nu_lat:.3g} in {kind}; the material has "
                         f"nu = {nu:g} (allowed within {NU_TOLERANCE})")
    return k1, k2, nu_lat


def square(origin, shape, spacing: float, E: float, nu: float, rho: float, thickness: float,
           kind: str = "plane_stress") -> Lattice:
    """Lattice of shape (nx, ny) particles from ``origin`` with ``spacing``."""
    nx, ny = shape
    k1, k2, _ = calibrate(E, nu, thickness, kind)
    t = thickness if kind == "plane_stress" else 1.0
    ix, iy = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    points = np.asarray(origin, float) + spacing * np.stack([ix.ravel(), iy.ravel()], axis=1)
    idx = np.arange(nx * ny).reshape(nx, ny)
    c00, c10, c01, c11 = idx[:-1, :-1], idx[1:, :-1], idx[:-1, 1:], idx[1:, 1:]
    contributions = (((0, 0), (1, 0), k1 / 2), ((0, 1), (1, 1), k1 / 2),
                     ((0, 0), (0, 1), k1 / 2), ((1, 0), (1, 1), k1 / 2),
                     ((0, 0), (1, 1), k2), ((1, 0), (0, 1), k2))
    mass = np.zeros(nx * ny)
    for corner in (c00, c10, c01, c11):
        np.add.at(mass, corner.ravel(), rho * t * spacing ** 2 / 4)
    corners = np.stack([c00.ravel(), c10.ravel(), c11.ravel(), c01.ravel()], axis=1)
    return Lattice(points, mass, spacing, corners, (nx, ny), contributions)


def cubic(origin, shape, spacing: float, E: float, nu: float, rho: float) -> Lattice:
    """3D lattice of shape (nx, ny, nz) particles: simple cubic with face diagonals."""
    nx, ny, nz = shape
    k_edge, k_diag, _ = calibrate(E, nu, spacing, "solid")
    grid = np.stack(np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij"), -1)
    points = np.asarray(origin, float) + spacing * grid.reshape(-1, 3)
    idx = np.arange(nx * ny * nz).reshape(nx, ny, nz)
    c = {(i, j, k): idx[i:nx - 1 + i, j:ny - 1 + j, k:nz - 1 + k].ravel()
         for i in (0, 1) for j in (0, 1) for k in (0, 1)}
    contributions = []
    for a in c:                                      # 12 edges, 12 face diagonals per cell
        for b in c:
            d = np.subtract(b, a)
            if tuple(a) >= tuple(b) or np.abs(d).sum() not in (1, 2) or np.abs(d).max() > 1:
                continue
            contributions.append((a, b, k_edge / 4 if np.abs(d).sum() == 1 else k_diag / 2))
    mass = np.zeros(nx * ny * nz)
    for corner in c.values():
        np.add.at(mass, corner, rho * spacing ** 3 / 8)
    corners = np.stack(list(c.values()), axis=1)
    return Lattice(points, mass, spacing, corners, (nx, ny, nz), tuple(contributions))


def simple_cubic(n: int, spacing: float = 1.0, k: float = 1.0, mass: float = 1.0):
    """n^3 particles on a simple cubic lattice with axis bonds (3 per particle
    away from the faces): (points [n^3, 3], bond_i, bond_j, stiffness, masses)."""
    idx = np.arange(n ** 3).reshape(n, n, n)
    g = np.stack(np.meshgrid(*(np.arange(n),) * 3, indexing="ij"), axis=-1).reshape(-1, 3)
    pairs = [(idx[:-1].ravel(), idx[1:].ravel()), (idx[:, :-1].ravel(), idx[:, 1:].ravel()),
             (idx[:, :, :-1].ravel(), idx[:, :, 1:].ravel())]
    bi = np.concatenate([a for a, _ in pairs])
    bj = np.concatenate([b for _, b in pairs])
    return spacing * g.astype(float), bi, bj, np.full(bi.size, k), np.full(n ** 3, mass)


def bond_triplets(points, bi, bj, k, dim=2):
    """COO stiffness of linearised central bonds: k n n^T blocks [[1, -1], [-1, 1]]."""
    n = points[bj] - points[bi]
    n /= np.linalg.norm(n, axis=1)[:, None]
    block = k[:, None, None] * np.einsum("bi,bj->bij", n, n)            # [nb, dim, dim]
    rows, cols, vals = [], [], []
    for a, b, sign in ((bi, bi, 1.0), (bj, bj, 1.0), (bi, bj, -1.0), (bj, bi, -1.0)):
        r = (a[:, None, None] * dim + np.arange(dim)[None, :, None]).repeat(dim, axis=2)
        c = (b[:, None, None] * dim + np.arange(dim)[None, None, :]).repeat(dim, axis=1)
        rows.append(r.ravel())
        cols.append(c.ravel())
        vals.append(sign * block.ravel())
    rows, cols, vals = np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)
    nz = vals != 0.0                      # axis-aligned bonds leave structural zeros
    return rows[nz], cols[nz], vals[nz]
