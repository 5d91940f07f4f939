"""Kernel throughput, as ratios in one run (1 rank).

    ./run.sh bench     (or: python benchmarks/bench_throughput.py [--h 0.06] [--lattice 1000])

1. Explicit FEM step on a 3D tetrahedral mesh (meshes/cube3d.geo, element size
   h): DOF-steps/s of the partition's Newmark step (MatMult + vector updates +
   diagonal solve) against PETSc's bare MatMult on the same matrix (target:
   >= 0.8x).
2. DEM bond step on a square lattice with diagonals of n x n particles:
   particle-steps/s of the velocity-Verlet step through the bond operator,
   against the memory bandwidth of a STREAM-like triad (a = b + s c) measured
   here: the bytes the step must move at least, divided by its time.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from solver.model.cell_blocks import group_matrices, nodal
from solver.partitions.assembly import assemble
from solver.model.elements import Elastic
from solver.model.lattice import bond_triplets, square
from solver.model.mesh import read
from solver.petscutil import aij, init, vec_on


def best(fn, repeat=5, number=20):
    """Best time per call over ``repeat`` batches of ``number`` calls."""
    times = []
    for _ in range(repeat):
        c0 = time.perf_counter()
        for _ in range(number):
            fn()
        times.append((time.perf_counter() - c0) / number)
    return min(times)


def triad(n=20_000_000):
    """Bytes/s of a = b + 3 c in numpy, which takes two passes: a = 3 c (read c,
    write a) then a += b (read a and b, write a): 5 x 8 bytes per element."""
    a, b, c = np.zeros(n), np.ones(n), np.ones(n)
    t = best(lambda: np.add(b, np.multiply(c, 3.0, out=a), out=a), repeat=5, number=3)
    return 5 * 8 * n / t


class Stepper:
    """Vecs and the explicit Newmark step of one partition, as the solver runs it."""

    def __init__(self, P, Kneg, mass, dt, beta=0.25, gamma=0.5):
        n = mass.size
        self.arrays = [np.zeros(n) for _ in range(6)]
        self.u, self.v, self.a, self.r, self.ut, self.vt = (vec_on(x, P.COMM_SELF) for x in self.arrays)
        self.minv = vec_on(1.0 / mass, P.COMM_SELF)
        self.K, self.h, self.beta, self.gamma = Kneg, dt, beta, gamma
        self.u.setRandom()

    def newmark(self):
        h, b, g = self.h, self.beta, self.gamma
        self.ut.waxpy(h, self.v, self.u)
        self.ut.axpy(h * h * (0.5 - b), self.a)
        self.vt.waxpy((1 - g) * h, self.a, self.v)
        self.K.mult(self.ut, self.r)
        self.a.pointwiseMult(self.r, self.minv)
        self.u.waxpy(b * h * h, self.a, self.ut)
        self.v.waxpy(g * h, self.a, self.vt)

    def verlet(self):
        h = self.h
        self.u.axpy(h, self.v)
        self.u.axpy(0.5 * h * h, self.a)
        self.v.axpy(0.5 * h, self.a)
        self.K.mult(self.u, self.r)
        self.a.pointwiseMult(self.r, self.minv)
        self.v.axpy(0.5 * h, self.a)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--h", type=float, default=0.03, help="tet element size in the unit cube (0.03: ~1e5 DOF)")
    ap.add_argument("--lattice", type=int, default=1000, help="lattice particles per side")
    args = ap.parse_args(argv)
    P = init([])
    bw = triad()
    print(f"STREAM-like triad: {bw / 1e9:.2f} GB/s")

    mesh = read("meshes/cube3d.geo", parameters={"h": args.h})
    mat = Elastic(70e9, 0.33, 2700)
    (fam, conn, Ke, me), = group_matrices(mesh, "solid", mat)
    n_nodes = len(mesh.points)
    K = assemble(Ke, conn, 3, n_nodes, P.COMM_SELF, "bench_", scale=-1.0)
    del Ke
    fem = Stepper(P, K, np.repeat(nodal(me, conn, n_nodes), 3), 1e-8)
    t_mult = best(lambda: K.mult(fem.ut, fem.r))
    t_step = best(fem.newmark)
    n = 3 * n_nodes
    nnz = int(K.getInfo()["nz_used"])
    print(f"\nexplicit FEM step, 3D tets: {len(conn)} tets, {n} DOF, {nnz} nonzeros (AIJ, bs 3)")
    print(f"  bare MatMult        {n / t_mult / 1e6:9.1f} M DOF-steps/s  ({1e3 * t_mult:.3f} ms)")
    print(f"  Newmark step        {n / t_step / 1e6:9.1f} M DOF-steps/s  ({1e3 * t_step:.3f} ms)")
    print(f"  step / MatMult throughput = {t_mult / t_step:.2f}   (target >= 0.8)")
    K.destroy()

    m = args.lattice
    lat = square((0, 0), (m, m), 1e-4, 70e9, 0.33, 2700, 3.2e-4)
    r, c, v = bond_triplets(lat.points, lat.bond_i, lat.bond_j, lat.stiffness)
    B = aij(r, c, v, 2 * m * m, P.COMM_SELF, "bench_", scale=-1.0, bs=2)
    dem = Stepper(P, B, np.repeat(lat.mass, 2), 1e-8)
    t_dem = best(dem.verlet, repeat=3, number=5)
    nb = lat.stiffness.size
    nnz = int(B.getInfo()["nz_used"])
    # least traffic: matrix values + column indices, the MatMult's input and output,
    # and the vector passes (3 axpy, 1 pointwise multiply, 1 axpy: 3 streams each)
    moved = nnz * (8 + 4) + 2 * m * m * 8 * (2 + 5 * 3)
    print(f"\nDEM bond step, square lattice with diagonals: {m * m} particles, {nb} bonds, "
          f"{nnz} operator nonzeros")
    print(f"  velocity Verlet     {m * m / t_dem / 1e6:9.1f} M particle-steps/s  "
          f"({1e3 * t_dem:.2f} ms, {1e9 * t_dem / nb:.2f} ns per bond)")
    print(f"  bytes moved / time  {moved / t_dem / 1e9:9.2f} GB/s = {moved / t_dem / bw:.2f} of the triad")


if __name__ == "__main__":
    main()
