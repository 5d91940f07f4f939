"""Random packings of bonded particles (``model.lattice.kind: random``).

A Poisson-disc packing (Bridson, "Fast Poisson disk sampling in arbitrary
dimensions", SIGGRAPH sketches, 2007) of a box: every particle has its own
radius r_i, drawn uniformly from r (1 - s) .. r (1 + s) (r half the
``spacing``, s the ``radius_spread``), and no two particles overlap
(|x_i - x_j| >= r_i + r_j).  Each new particle is tried in the shell
(r_p + r_q) .. 2 (r_p + r_q) around an active one, 30 tries before that one
retires, so the box is filled until hardly a particle of the mean radius
fits (with a spread, holes for the smallest ones remain).  The draw is a
function of the seed alone, so a scene is reproducible and the same on any
number of ranks.

Two particles are bonded when they are Delaunay neighbours and their
surfaces are at most ``gap`` x their mean diameter apart:
|x_i - x_j| <= (r_i + r_j)(1 + gap).  Bonds are central
(a spring k along the line of centres) with k = kappa E A / L, L the bond's
length, A its cross-section (2 r t in 2D, t the thickness, pi r^2 in 3D, r
the pair's mean radius), and one factor kappa for the whole packing: the
calibration (:mod:`solver.model.calibration`) measures the packing's E and
nu on a uniaxial test of a sample packed with the same settings and sets
kappa so that E is the material's.  Particle masses are rho times the
region's area (volume) shared in proportion to r_i^dim.
"""
from __future__ import annotations

import numpy as np

ATTEMPTS = 30
SHELL = 1.0         # candidates at (r_p + r_q)(1 + SHELL u), u uniform in [0, 1): Bridson's annulus
MAX_PARTICLES = 5_000_000


def _kernel():
    """The compiled sampler (numba loads when a random packing is built)."""
    import numba  # lazy: numba (about 1 s to import) loads only when a packing is drawn

    @numba.njit(cache=True)
    def bridson(lo, hi, r_mean, spread, seed, attempts, offsets, cap, shell):
        np.random.seed(seed)
        dim = lo.size
        cell = 2.0 * r_mean * (1.0 - spread) / np.sqrt(dim)
        m = np.empty(dim, np.int64)
        for c in range(dim):
            m[c] = max(1, int(np.ceil((hi[c] - lo[c]) / cell)))
        stride = np.ones(dim, np.int64)
        for c in range(dim - 2, -1, -1):
            stride[c] = stride[c + 1] * m[c + 1]
        # a cell holds at most one centre (its diagonal is below the smallest
        # distance between centres)
        grid = -np.ones(stride[0] * m[0], np.int64)
        pts = np.empty((cap, dim))
        rad = np.empty(cap)
        active = np.empty(cap, np.int64)
        q = np.empty(dim)
        g = np.empty(dim, np.int64)

        def radius():
            return r_mean * (1.0 + spread * (2.0 * np.random.random() - 1.0))

        for c in range(dim):
            pts[0, c] = lo[c] + (hi[c] - lo[c]) * np.random.random()
        rad[0] = radius()
        at = 0
        for c in range(dim):
            at += min(int((pts[0, c] - lo[c]) / cell), m[c] - 1) * stride[c]
        grid[at] = 0
        n, n_active = 1, 1
        active[0] = 0
        while n_active and n < cap:
            slot = np.random.randint(n_active)
            p = active[slot]
            placed = False
            for _ in range(attempts):
                rq = radius()
                dist = (rad[p] + rq) * (1.0 + shell * np.random.random())
                norm = 0.0
                for c in range(dim):
                    q[c] = np.random.normal()
                    norm += q[c] * q[c]
                norm = np.sqrt(norm)
                inside = True
                for c in range(dim):
                    q[c] = pts[p, c] + dist * q[c] / norm
                    if q[c] < lo[c] or q[c] > hi[c]:
                        inside = False
                if not inside:
                    continue
                for c in range(dim):
                    g[c] = min(int((q[c] - lo[c]) / cell), m[c] - 1)
                free = True
                for o in range(offsets.shape[0]):
                    at = 0
                    for c in range(dim):
                        x = g[c] + offsets[o, c]
                        if x < 0 or x >= m[c]:
                            at = -1
                            break
                        at += x * stride[c]
                    if at < 0:
                        continue
                    other = grid[at]
                    if other >= 0:
                        d2 = 0.0
                        for c in range(dim):
                            d2 += (pts[other, c] - q[c]) ** 2
                        if d2 < (rad[other] + rq) ** 2:
                            free = False
                            break
                if free:
                    at = 0
                    for c in range(dim):
                        at += g[c] * stride[c]
                    pts[n] = q
                    rad[n] = rq
                    grid[at] = n
                    active[n_active] = n
                    n += 1
                    n_active += 1
                    placed = True
                    break
            if not placed:
                n_active -= 1
                active[slot] = active[n_active]
        return pts[:n].copy(), rad[:n].copy()

    return bridson


_BRIDSON = None


def estimate(lo, hi, radius: float) -> float:
    """An upper bound of how many particles of ``radius`` the box [lo, hi]
    holds: its area (volume) over one particle's (maximal packings fill about
    half of it)."""
    box = np.prod(np.asarray(hi, float) - np.asarray(lo, float))
    dim = len(lo)
    one = np.pi * radius ** 2 if dim == 2 else 4.0 / 3.0 * np.pi * radius ** 3
    return box / one


def poisson_disc(lo, hi, radius: float, spread: float = 0.0, seed: int = 0):
    """(points [n, dim], radii [n]) of a maximal Poisson-disc packing of the box
    [lo, hi] with radii uniform in radius (1 -+ spread), seeded.  Points are
    in cell order (neighbours near in memory)."""
    global _BRIDSON
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    dim = lo.size
    if not 0.0 <= spread < 1.0:
        raise ValueError(f"radius spread {spread:g} must be in [0, 1)")
    n_est = estimate(lo, hi, radius * (1.0 - spread))
    if n_est > MAX_PARTICLES:
        raise ValueError(f"radius {radius:g} m would give about {n_est:.3g} particles "
                         f"(limit {MAX_PARTICLES:.0e})")
    if _BRIDSON is None:
        _BRIDSON = _kernel()
    # neighbour cells within reach of the largest diameter
    cell = 2.0 * radius * (1.0 - spread) / np.sqrt(dim)
    reach = int(np.ceil(2.0 * radius * (1.0 + spread) / cell))
    axes = np.arange(-reach, reach + 1)
    offsets = np.stack(np.meshgrid(*(axes,) * dim, indexing="ij"), -1).reshape(-1, dim)
    cap = int(1.3 * n_est) + 64
    pts, rad = _BRIDSON(lo, hi, float(radius), float(spread), int(seed) % (2 ** 32), ATTEMPTS,
                        offsets.astype(np.int64), cap, SHELL)
    key = np.floor((pts - lo) / (4.0 * radius)).astype(np.int64)
    m = int(key.max()) + 1 if len(key) else 1
    flat = np.zeros(len(pts), np.int64)
    for c in range(dim):
        flat = flat * m + key[:, c]
    order = np.argsort(flat, kind="stable")
    return pts[order], rad[order]


def neighbour_pairs(points, radii, gap: float):
    """Bonds (i, j), i < j, sorted: the edges of the points' Delaunay
    triangulation (tetrahedralisation) whose particles' surfaces are at most
    ``gap`` x their mean diameter apart, |x_i - x_j| <= (r_i + r_j)(1 + gap).
    Delaunay edges join each particle to the neighbours around it (a
    triangulated network is rigid with central bonds); the gap cuts the long
    edges across the hull and across a region's concave corners."""
    from scipy.spatial import Delaunay  # lazy: scipy loads only for a random packing
    dim = points.shape[1]
    if len(points) <= dim:
        return np.empty(0, np.int64), np.empty(0, np.int64)
    simplices = Delaunay(points).simplices
    a, b = np.triu_indices(dim + 1, 1)
    edges = np.sort(np.concatenate([simplices[:, [p, q]] for p, q in zip(a, b)]), axis=1)
    edges = np.unique(edges.astype(np.int64), axis=0)
    i, j = edges[:, 0], edges[:, 1]
    d = np.linalg.norm(points[j] - points[i], axis=1)
    keep = d <= (radii[i] + radii[j]) * (1.0 + gap)
    return i[keep], j[keep]


def bond_stiffness(points, radii, i, j, E: float, depth: float, kappa: float = 1.0):
    """k = kappa E A / L of central bonds (i, j): A = 2 r t in 2D (``depth`` t),
    pi r^2 in 3D, r the pair's mean radius."""
    r = 0.5 * (radii[i] + radii[j])
    L = np.linalg.norm(points[j] - points[i], axis=1)
    area = 2.0 * r * depth if points.shape[1] == 2 else np.pi * r ** 2
    return kappa * E * area / L


def masses(radii, dim: int, total: float):
    """``total`` mass shared in proportion to r^dim."""
    w = radii ** dim
    return total * w / w.sum()
