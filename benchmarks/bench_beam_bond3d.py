"""The 3D beam-bond loop (rotating particles) against the memory-bandwidth limit
and against the numpy law doing the same physics.

    python benchmarks/bench_beam_bond3d.py [--side 54]     (about 2 minutes)

A random packing of a cube of side ``side`` spacings (Poisson-disc, Delaunay
bonds within gap 1: solver/model/packing.py; side 54: about 100,000
particles and 650,000 bonds) at a random deformation (displacements 1e-3 of
the spacing, rotations 1e-3 rad from orientations turned by up to 1 rad).
Times, best of 5 repeats of 5 calls each (numpy: 3 x 1), in one process:
- the compiled loop (solver/partitions/beam_bond3d_kernel.py): one pass over
  the particles for their rotation matrices (each orientation's quaternion
  turned by its rotation DOFs' increment), one over the bonds;
- the numpy law (solver/partitions/beam_bond3d.py: BeamBonds3D.forces), the
  reference;
- the central-bond loop (solver/partitions/bond_kernel.py) on the same bonds,
  for scale: what rotations, bending and torsion cost;
- a STREAM-like triad (numpy, a = b + 3 c; bench_throughput.py's), the
  bandwidth limit.
The loop's least traffic: per bond the rest separation and length, four
stiffnesses, two indices, its tensile limit and live flag (89 B); per particle
its q = (u, theta), quaternion and last theta read once, its (forces, moments)
read and written, and its R (a 3 x 3 matrix) written by the first pass and
read by the second (344 B).
Writes results/bench_beam_bond3d.md and docs/benchmarks/bench_beam_bond3d.md.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
from bench_beam_bond import packed, report  # noqa: E402
from bench_throughput import best  # noqa: E402
from tables import write  # noqa: E402

from solver.partitions.orientation import Orientation  # noqa: E402
from solver.partitions.beam_bond3d import BeamBonds3D  # noqa: E402
from solver.partitions.beam_bond3d_kernel import beam_forces3d  # noqa: E402

BOND_BYTES, PARTICLE_BYTES = 89, 344


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--side", type=float, default=54.0)
    args = ap.parse_args(argv)
    x, i, j, k, L = packed(3, args.side)
    k_b = 0.3 * k * L ** 2 / 12.0
    bonds = BeamBonds3D(i, j, x[j] - x[i], k, k_b, k_b)
    rng = np.random.default_rng(0)
    q = rng.normal(0.0, 1e-3, (len(x), 6))
    turned = Orientation(rng.normal(0.0, 0.5, (len(x), 3)))     # the orientations at last
    turned.last[:] = q[:, 3:] - rng.normal(0.0, 1e-3, (len(x), 3))
    R = np.empty((len(x), 3, 3))
    out = np.zeros((len(x), 6))
    beam_forces3d(bonds, q, out, orientation=turned, R=R)       # compile
    f, t = bonds.forces(q[:, :3], turned.frames(q[:, 3:]))
    agree = np.abs(out - np.hstack([f, t])).max() / np.abs(f).max()
    t_loop = best(lambda: beam_forces3d(bonds, q, out, orientation=turned, R=R), repeat=5,
                  number=5)
    t_numpy = best(lambda: bonds.forces(q[:, :3], turned.frames(q[:, 3:])), repeat=3, number=1)
    lines = report("3D", x, i, j, k, L, q[:, :3], t_loop, t_numpy, agree, BOND_BYTES,
                   PARTICLE_BYTES, "5 x 5 (numpy: 3 x 1)",
                   "per bond two 3 x 3 products for the tilts, one for R_i^T R_j and three "
                   "for the moments back in space: about 200 flops")
    write("bench_beam_bond3d", lines, doc=True)


if __name__ == "__main__":
    main()
