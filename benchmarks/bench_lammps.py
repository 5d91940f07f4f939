"""DEM bond step against LAMMPS, side by side on this machine (1 core).

    python benchmarks/bench_lammps.py [--n 60] [--steps 1000]

The case: a 60^3 simple-cubic lattice, 216,000 atoms with 3 harmonic bonds
each, NVE.  LAMMPS (Debian's ``lammps`` package, ``lmp``) runs it with periodic
boundaries; we step velocity Verlet with PETSc Vec operations, as a dem
partition does, on the same lattice (open boundaries: 3 bonds per atom away
from the faces), with three bond forces:

- the bond operator (linearised central bonds, AIJ with block size 3): the
  small-strain lattice, ``geometry: linear``;
- bonds from the current configuration (``geometry: nonlinear``, breakable),
  the same physics as LAMMPS's harmonic bonds: the compiled loop of
  solver/partitions/bond_kernel.py, which the solver uses;
- the same bonds in numpy (gather, multiply, bincount), the reference the
  loop replaced.

Reported: atom-steps/s and ns per bond for each, and their ratios to LAMMPS.  LAMMPS is not installed by run.sh
(its package switches the system mpiexec to OpenMPI); without ``lmp`` on PATH
only our figure is printed.
"""
from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

from solver.model.lattice import bond_triplets, simple_cubic
from solver.petscutil import aij, init, vec_on

LAMMPS_INPUT = """units lj
atom_style bond
boundary p p p
lattice sc 1.0
region box block 0 {n} 0 {n} 0 {n}
create_box 1 box bond/types 1 extra/bond/per/atom 6 extra/special/per/atom 6
create_atoms 1 box
mass 1 1.0
pair_style zero 1.1
pair_coeff * *
bond_style harmonic
bond_coeff 1 100.0 1.0
create_bonds many all all 1 0.99 1.01
velocity all create 0.01 4928459 loop geom
fix 1 all nve
timestep 0.001
thermo {steps}
run {steps}
"""


def ours(n, steps):
    P = init([])
    pts, bi, bj, k, m = simple_cubic(n, 1.0, 100.0, 1.0)
    r, c, v = bond_triplets(pts, bi, bj, k, dim=3)
    B = aij(r, c, v, 3 * n ** 3, P.COMM_SELF, "lmp_", scale=-1.0, bs=3)
    arrs = [np.zeros(3 * n ** 3) for _ in range(4)]
    u, vel, a, f = (vec_on(x, P.COMM_SELF) for x in arrs)
    minv = vec_on(np.repeat(1.0 / m, 3), P.COMM_SELF)
    vel.setRandom()
    h = 0.001
    t0 = time.perf_counter()
    for _ in range(steps):
        u.axpy(h, vel)
        u.axpy(0.5 * h * h, a)
        vel.axpy(0.5 * h, a)
        B.mult(u, f)
        a.pointwiseMult(f, minv)
        vel.axpy(0.5 * h, a)
    t = (time.perf_counter() - t0) / steps
    return n ** 3 / t, 1e9 * t / bi.size, bi.size


def nonlinear(n, steps, compiled=True):
    """Velocity Verlet with bonds from the current configuration (never breaking)."""
    from solver.partitions.bond_kernel import bond_forces
    P = init([])
    pts, bi, bj, k, m = simple_cubic(n, 1.0, 100.0, 1.0)
    N = n ** 3
    arrs = [np.zeros(3 * N) for _ in range(4)]
    u, vel, a, f = (vec_on(x, P.COMM_SELF) for x in arrs)
    U, F = arrs[0].reshape(N, 3), arrs[3].reshape(N, 3)
    minv = vec_on(np.repeat(1.0 / m, 3), P.COMM_SELF)
    vel.setRandom()
    vel.scale(0.01)
    L0 = np.linalg.norm(pts[bj] - pts[bi], axis=1)
    alive, limit = np.ones(bi.size, bool), np.full(bi.size, np.inf)
    snapped = np.zeros(bi.size, dtype=np.int64)
    order = np.lexsort((bj, bi))              # as BondForce sorts them
    bi, bj, k, L0 = bi[order].astype(np.int64), bj[order].astype(np.int64), k[order], L0[order]

    dX = pts[bj] - pts[bi]                    # rest separations (as BondForce keeps them)

    def force():
        if compiled:
            bond_forces(dX, U, bi, bj, k, L0, alive, limit, F, N, snapped, False)
            return
        d = dX + (U[bj] - U[bi])
        L = np.linalg.norm(d, axis=1)
        g = (k * (L - L0) / L)[:, None] * d
        for c in range(3):
            F[:, c] = np.bincount(bi, g[:, c], minlength=N) - np.bincount(bj, g[:, c], minlength=N)

    force()                                   # compiles the loop (cached on disk)
    h = 0.001
    t0 = time.perf_counter()
    for _ in range(steps):                    # as solver/partitions/integrators.py steps
        u.maxpy((h, 0.5 * h * h), (vel, a))
        vel.axpy(0.5 * h, a)
        force()
        a.pointwiseMult(f, minv)
        vel.axpy(0.5 * h, a)
    t = (time.perf_counter() - t0) / steps
    return N / t, 1e9 * t / bi.size, bi.size


def lammps(n, steps):
    exe = shutil.which("lmp")
    if not exe:
        return None
    tmp = Path(tempfile.mkdtemp())
    (tmp / "in.bonds").write_text(LAMMPS_INPUT.format(n=n, steps=steps))
    out = subprocess.run([exe, "-in", "in.bonds", "-log", "none"], cwd=tmp, capture_output=True,
                         text=True, env={**os.environ, "OMP_NUM_THREADS": "1"})
    m = re.search(r"Loop time of ([\d.eE+-]+) on 1 procs for (\d+) steps with (\d+) atoms", out.stdout)
    if not m:
        raise SystemExit(f"LAMMPS did not report a loop time:\n{out.stdout[-1500:]}{out.stderr[-1500:]}")
    t, s, atoms = float(m.group(1)), int(m.group(2)), int(m.group(3))
    bonds = re.search(r"(\d+) bonds", out.stdout)
    nb = int(bonds.group(1)) if bonds else 3 * atoms
    return atoms * s / t, 1e9 * t / s / nb, nb


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=60)
    ap.add_argument("--steps", type=int, default=1000)
    args = ap.parse_args(argv)
    steps = max(args.steps // 5, 50)
    rows = [("ours, bond operator (linear, AIJ bs 3)", ours(args.n, steps)),
            ("ours, current-configuration bonds, compiled", nonlinear(args.n, steps)),
            ("ours, current-configuration bonds, numpy", nonlinear(args.n, max(steps // 5, 10),
                                                                   compiled=False))]
    print(f"simple cubic {args.n}^3 = {args.n ** 3} atoms")
    for label, (rate, per_bond, nb) in rows:
        print(f"  {label:45s} {rate / 1e6:7.1f} M atom-steps/s, {per_bond:6.2f} ns per bond "
              f"({nb} bonds)")
    compiled, numpy_rate = rows[1][1][0], rows[2][1][0]
    print(f"  compiled / numpy throughput = {compiled / numpy_rate:.2f}")
    lmp = lammps(args.n, args.steps)
    if lmp is None:
        print("  LAMMPS: 'lmp' not found (apt-get install lammps to compare; it switches mpiexec "
              "to OpenMPI)")
        return
    print(f"  {'LAMMPS (harmonic bonds, NVE)':45s} {lmp[0] / 1e6:7.1f} M atom-steps/s, "
          f"{lmp[1]:6.2f} ns per bond ({lmp[2]} bonds)")
    for label, (rate, _, _) in rows[:2]:
        print(f"  {label} / LAMMPS throughput = {rate / lmp[0]:.2f}")


if __name__ == "__main__":
    main()
