"""DEM bond step against LAMMPS, side by side on this machine (1 core).

    python benchmarks/bench_lammps.py [--n 60] [--steps 1000]

The issue's case: a 60^3 simple-cubic lattice, 216,000 atoms with 3 harmonic
bonds each, NVE.  LAMMPS (Debian's ``lammps`` package, ``lmp``) runs it with
periodic boundaries; our DEM partition steps velocity Verlet through the bond
operator (linearised central bonds, AIJ with block size 3) on the same lattice
(open boundaries: 3 bonds per atom away from the faces).  Reported: atom-steps/s
and ns per bond for both, and their ratio.  LAMMPS is not installed by run.sh
(its package switches the system mpiexec to OpenMPI); without ``lmp`` on PATH
only our figure is printed.
"""
from __future__ import annotations

import argparse
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


def lammps(n, steps):
    exe = shutil.which("lmp")
    if not exe:
        return None
    tmp = Path(tempfile.mkdtemp())
    (tmp / "in.bonds").write_text(LAMMPS_INPUT.format(n=n, steps=steps))
    out = subprocess.run([exe, "-in", "in.bonds", "-log", "none"], cwd=tmp, capture_output=True,
                         text=True, env={"OMP_NUM_THREADS": "1", "PATH": "/usr/bin:/bin"})
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
    rate, per_bond, nb = ours(args.n, max(args.steps // 5, 50))
    print(f"simple cubic {args.n}^3 = {args.n ** 3} atoms")
    print(f"  ours (bond operator, AIJ bs 3): {rate / 1e6:7.1f} M atom-steps/s, {per_bond:.2f} ns per bond ({nb} bonds)")
    lmp = lammps(args.n, args.steps)
    if lmp is None:
        print("  LAMMPS: 'lmp' not found (apt-get install lammps to compare; it switches mpiexec to OpenMPI)")
        return
    print(f"  LAMMPS (harmonic bonds, NVE):    {lmp[0] / 1e6:7.1f} M atom-steps/s, {lmp[1]:.2f} ns per bond ({lmp[2]} bonds)")
    print(f"  ours / LAMMPS throughput = {rate / lmp[0]:.2f}")


if __name__ == "__main__":
    main()
