"""The 2D beam-bond loop (rotating particles) against the memory-bandwidth limit
and against the numpy law doing the same physics.

    python benchmarks/bench_beam_bond.py [--side 400]     (about 1 minute)

A random packing of a square of side ``side`` spacings (Poisson-disc, Delaunay
bonds within gap 1: solver/model/packing.py; side 400: about 106,000
particles and 306,000 bonds) at a random deformation (displacements 1e-3 of
the spacing, rotations 1e-3 rad).  Times, best of 5 repeats of 10 calls each,
in one process:
- the compiled loop (solver/partitions/beam_bond_kernel.py), one pass over the
  bonds sorted by their first particle;
- the numpy law (solver/partitions/beam_bond.py: BeamBonds.forces), the
  reference;
- the central-bond loop of today's lattices (solver/partitions/bond_kernel.py)
  on the same bonds, for scale: what rotations and bending cost;
- a STREAM-like triad (numpy, a = b + 3 c; bench_throughput.py's) on this
  machine, the bandwidth limit.
The loop's traffic is counted as the bytes it must move at least: per bond
the rest separation and length, three stiffnesses, two indices, its tensile
limit and live flag (73 B: the loop tests them even for unbreakable bonds),
per particle its (u_x, u_y, theta) read once and (f_x, f_y, torque)
read and written (72 B).  Its time against that traffic over the triad's
bandwidth says whether the loop is limited by memory or by arithmetic
(each bond takes a sqrt, three divisions and, beyond 0.01 rad of chord
rotation, an atan2; below, atan's series).
Writes results/bench_beam_bond.md and docs/benchmarks/bench_beam_bond.md.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
from bench_throughput import best, triad  # noqa: E402
from tables import write  # noqa: E402

from solver.model import packing  # noqa: E402
from solver.partitions.beam_bond import BeamBonds  # noqa: E402
from solver.partitions.beam_bond_kernel import beam_forces  # noqa: E402
from solver.partitions.bond_kernel import bond_forces  # noqa: E402

BOND_BYTES, PARTICLE_BYTES = 73, 72


def report(space, x, i, j, k, L, u, t_loop, t_numpy, agree, bond_bytes, particle_bytes,
           repeats, arithmetic) -> list[str]:
    """The page's lines: the beam loop's time ``t_loop`` against numpy's
    ``t_numpy``, the central-bond loop on the same bonds (timed here, at the
    displacements ``u``) and the least traffic at the triad's bandwidth."""
    dX, u, out = x[j] - x[i], np.ascontiguousarray(u), np.zeros(x.shape)
    alive, limit = np.ones(i.size, bool), np.full(i.size, np.inf)
    snapped = np.zeros(i.size, np.int64)
    central = (dX, u, i, j, k, L, alive, limit, out, len(x), snapped, False)
    bond_forces(*central)
    t_central = best(lambda: bond_forces(*central), repeat=5, number=10)
    bw = triad()
    nb, n = i.size, len(x)
    traffic = nb * bond_bytes + n * particle_bytes
    t_limit = traffic / bw
    return [f"# {space} beam bonds: the compiled loop against the bandwidth limit and numpy", "",
            f"Random packing of {n} particles, {nb} beam bonds ({2 * nb / n:.2f} per particle); "
            f"one force-and-torque evaluation, best of {repeats} in one process.  "
            f"Least traffic: {bond_bytes} B per bond + {particle_bytes} B per particle = "
            f"{traffic / 1e6:.1f} MB per evaluation; triad bandwidth here "
            f"{bw / 1e9:.1f} GB/s.", "",
            "| evaluation | ms | ns per bond | GB/s of least traffic | / triad | vs numpy |",
            "|---|---|---|---|---|---|",
            f"| compiled loop | {1e3 * t_loop:.2f} | {1e9 * t_loop / nb:.2f} | "
            f"{traffic / t_loop / 1e9:.1f} | {t_limit / t_loop:.2f} | "
            f"{t_numpy / t_loop:.1f}x faster |",
            f"| numpy law (reference) | {1e3 * t_numpy:.2f} | {1e9 * t_numpy / nb:.2f} | "
            f"{traffic / t_numpy / 1e9:.2f} | {t_limit / t_numpy:.3f} | 1 |",
            f"| central bonds, no rotation (bond_kernel) | {1e3 * t_central:.2f} | "
            f"{1e9 * t_central / nb:.2f} | | | |",
            f"| bandwidth limit (least traffic / triad) | {1e3 * t_limit:.2f} | "
            f"{1e9 * t_limit / nb:.2f} | {bw / 1e9:.1f} | 1 | |", "",
            f"The loop and numpy agree to {agree:.1e} of the largest force.  The loop runs at "
            f"{100 * t_limit / t_loop:.0f} % of the bandwidth limit: "
            + (f"it is limited by arithmetic ({arithmetic}), not by memory."
               if t_loop > 2 * t_limit else "it is close to the memory limit.")]


def packed(dim: int, side: float):
    """(positions, bond ends i and j, axial stiffnesses, lengths) of the
    seeded Poisson-disc packing of a square or cube of ``side`` spacings,
    Delaunay bonds within gap 1 (E = 1, unit thickness)."""
    x, r = packing.poisson_disc(np.zeros(dim), np.full(dim, side), 0.5, 0.0, seed=1)
    i, j = packing.neighbour_pairs(x, r, 1.0)
    k = packing.bond_stiffness(x, r, i, j, 1.0, 1.0)
    return x, i, j, k, np.linalg.norm(x[j] - x[i], axis=1)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--side", type=float, default=400.0)
    args = ap.parse_args(argv)
    x, i, j, k, L = packed(2, args.side)
    bonds = BeamBonds(i, j, x[j] - x[i], k, 0.3 * k * L ** 2 / 12.0)
    rng = np.random.default_rng(0)
    q = np.column_stack([rng.normal(0.0, 1e-3, x.shape), rng.normal(0.0, 1e-3, len(x))])
    out = np.zeros((len(x), 3))
    beam_forces(bonds, q, out)                                  # compile
    f, t = bonds.forces(q[:, :2], q[:, 2])
    agree = max(np.abs(out[:, :2] - f).max(), np.abs(out[:, 2] - t).max()) / np.abs(f).max()
    t_loop = best(lambda: beam_forces(bonds, q, out), repeat=5, number=10)
    t_numpy = best(lambda: bonds.forces(q[:, :2], q[:, 2]), repeat=3, number=2)
    lines = report("2D", x, i, j, k, L, q[:, :2], t_loop, t_numpy, agree, BOND_BYTES,
                   PARTICLE_BYTES, "5 x 10 (numpy: 3 x 2)",
                   "a sqrt, three divisions and, beyond 0.01 rad of chord rotation, an atan2 "
                   "per bond")
    write("bench_beam_bond", lines, doc=True)


if __name__ == "__main__":
    main()
