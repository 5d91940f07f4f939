"""A cantilever of beam-bonded particles against the continuum.

    python benchmarks/bench_cantilever.py [--nu 0.25] [--seeds 1 2 3 4]   (about 10 s)

A random packing (solver/model/packing.py: Poisson-disc, radius 1/2, spread
0, Delaunay bonds within gap 1) fills a strip of depth H and length 8 H
(in spacings, unit thickness, plane stress); its beam bonds are calibrated
to E = 1 and ``nu`` (solver/model/calibration.py: calibrate_beams, the
same calibration as ``model.lattice.bond: beam``).  The particles within
one spacing of the left end are clamped (u = 0, theta = 0), those within
one spacing of the right end share a transverse tip load P; one sparse LU
solve (SciPy) of the linear beam network gives the tip deflection (the tip
particles' mean).  The reference is the same strip of plane-stress
bilinear quadrilaterals (our element library), the nodes within a
spacing of the ends held and loaded the same way, at h = 1/2 and 1/4
spacing, Richardson-extrapolated (second order); Timoshenko's formula
P L^3/(3EI) + P L/(kappa G A) is 1-2 % off that continuum at these
proportions, with the clamp and load spread over a spacing.  The ratio
per depth and seed says how well a packing that deep reproduces a
continuum beam (a chain of beam bonds is the beam element itself:
tests/test_beam_bond.py, 3e-8).
Writes results/bench_cantilever.md and docs/benchmarks/bench_cantilever.md.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from solver.model import calibration, packing  # noqa: E402
from solver.model.elements import FAMILIES, Elastic, stiffness  # noqa: E402
from tables import write  # noqa: E402

GRIP = 1.0      # the clamp and the load act within this of the ends [spacings]
LOAD = 1.0e-3   # the tip load (E = 1, unit thickness)


def tip_deflection(nu: float, depth: float, seed: int):
    """(particles, bonds, tip deflection) of one packed cantilever (tip load 1e-3)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.linalg import spsolve
    kappa, psi, _ = calibration.calibrate_beams(1.0, nu, "plane_stress", 0.0, 1.0, 0)
    length = 8.0 * depth
    x, r = packing.poisson_disc(np.zeros(2), np.array([length, depth]), 0.5, 0.0, seed)
    i, j = packing.neighbour_pairs(x, r, 1.0)
    k = packing.bond_stiffness(x, r, i, j, 1.0, 1.0, kappa)
    k_b = psi * k * np.sum((x[j] - x[i]) ** 2, axis=1) / 12.0
    rows, cols, vals, _ = calibration._coo(i, j, calibration.beam_blocks(x[j] - x[i], k, k_b))
    n = 3 * len(x)
    K = coo_matrix((vals, (rows, cols)), shape=(n, n)).tocsr()
    clamp, tip = np.flatnonzero(x[:, 0] < GRIP), np.flatnonzero(x[:, 0] > length - GRIP)
    free = np.ones(n, bool)
    free[(clamp[:, None] * 3 + np.arange(3)).ravel()] = False
    f = np.zeros(n)
    f[tip * 3 + 1] = -LOAD / tip.size
    u = np.zeros(n)
    u[free] = spsolve(K[free][:, free].tocsc(), f[free])
    return len(x), len(i), float(-u[tip * 3 + 1].mean())


def continuum(nu: float, depth: float, h: float) -> float:
    """Tip deflection of the same strip [0, 8 H] x [0, H] of plane-stress bilinear
    quadrilaterals of size h (solver/model/elements.py), E = 1: the nodes within
    GRIP of the left end held, the load shared equally by those within GRIP of
    the right end, the deflection their mean, as for the particles."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.linalg import spsolve
    length = 8.0 * depth
    nx, ny = int(round(length / h)), int(round(depth / h))
    X, Y = np.meshgrid(np.linspace(0, length, nx + 1), np.linspace(0, depth, ny + 1),
                       indexing="ij")
    pts = np.stack([X.ravel(), Y.ravel()], axis=1)
    at = np.arange(len(pts)).reshape(nx + 1, ny + 1)
    conn = np.stack([at[:-1, :-1], at[1:, :-1], at[1:, 1:], at[:-1, 1:]], -1).reshape(-1, 4)
    Ke = stiffness(FAMILIES["quad4"], pts[conn], Elastic(1.0, nu, 1.0, "plane_stress"))
    dofs = (conn[:, :, None] * 2 + np.arange(2)).reshape(len(conn), -1)
    n = 2 * len(pts)
    K = coo_matrix((Ke.ravel(), (np.repeat(dofs, 8, axis=1).ravel(),
                                 np.tile(dofs, (1, 8)).ravel())), shape=(n, n)).tocsr()
    clamp = np.flatnonzero(pts[:, 0] <= GRIP + 1e-9)
    tip = np.flatnonzero(pts[:, 0] >= length - GRIP - 1e-9)
    free = np.ones(n, bool)
    free[np.concatenate([clamp * 2, clamp * 2 + 1])] = False
    f = np.zeros(n)
    f[tip * 2 + 1] = -LOAD / tip.size
    u = np.zeros(n)
    u[free] = spsolve(K[free][:, free].tocsc(), f[free])
    return float(-u[tip * 2 + 1].mean())


def reference(nu: float, depth: float) -> tuple[float, float]:
    """(the continuum's tip deflection, Richardson-extrapolated from h = 1/2 and
    1/4 spacing (bilinear: second order), its change from h = 1/4)."""
    coarse, fine = continuum(nu, depth, 0.5), continuum(nu, depth, 0.25)
    best = fine + (fine - coarse) / 3.0
    return best, abs(best / fine - 1.0)


def timoshenko(nu: float, depth: float) -> float:
    """P L^3 / (3 E I) + P L / (kappa G A), L the span between the grips' middles."""
    span = 8.0 * depth - GRIP
    G = 1.0 / (2.0 * (1.0 + nu))
    return LOAD * span ** 3 / (3.0 * depth ** 3 / 12.0) + LOAD * span / (5.0 / 6.0 * G * depth)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--nu", type=float, default=0.25)
    ap.add_argument("--depths", type=float, nargs="+", default=[12.0, 16.0, 20.0, 24.0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4])
    args = ap.parse_args(argv)
    lines = ["# A cantilever of beam-bonded particles against the continuum", "",
             f"Random packings (spread 0, gap 1) of depth H and length 8 H spacings, beam bonds "
             f"calibrated to E = 1, nu = {args.nu:g} (plane stress; calibration on 4 samples of "
             "seed 0); clamped over the first spacing, tip load over the last; tip deflection "
             "over the same strip's of plane-stress bilinear quadrilaterals (h = 1/2 and 1/4 "
             "spacing, Richardson-extrapolated).", "",
             "| depth H [spacings] | particles | " +
             " | ".join(f"seed {s}" for s in args.seeds) + " | mean | spread (max - min) | "
             "continuum / Timoshenko | continuum's last refinement |",
             "|---|---|" + "---|" * (len(args.seeds) + 4)]
    for depth in args.depths:
        ref, change = reference(args.nu, depth)
        got = [tip_deflection(args.nu, depth, s) for s in args.seeds]
        ratios = np.array([g[2] for g in got]) / ref
        lines.append(f"| {depth:g} | {got[0][0]} | " +
                     " | ".join(f"{x:.3f}" for x in ratios) +
                     f" | {ratios.mean():.3f} | {np.ptp(ratios):.3f} | "
                     f"{ref / timoshenko(args.nu, depth):.3f} | {change:.1e} |")
    lines += ["", "A ratio below 1: the packing is stiffer in bending than the continuum of the "
              "calibrated E and nu.  Timoshenko's formula (span between the grips' middles, "
              "kappa = 5/6) is itself 1-2 % off the continuum with the grips spread over a "
              "spacing, so the reference is the continuum of the same strip, clamp and load.  "
              "A packing's E scatters by 1.7 % from seed to seed (60 x 60 samples; "
              "docs/bonds.md), which is what the spread between seeds shows."]
    default = (args.nu, args.depths, args.seeds) == (0.25, [12.0, 16.0, 20.0, 24.0], [1, 2, 3, 4])
    write("bench_cantilever", lines, doc=default)


if __name__ == "__main__":
    main()
