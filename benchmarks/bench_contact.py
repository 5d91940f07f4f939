"""Contact detection cost per particle-step (solver/partitions/contact.py).

    python benchmarks/bench_contact.py [--n 100] [--steps 200]
    mpiexec -n N python benchmarks/bench_contact.py --halo [--radius 0.5]   # N slabs' halos

A square lattice of n x n particles (spacing a, radius a/2) jiggles with
random velocities of 1e-3 a per step; each step calls Contact.forces (the search
is rebuilt when a particle has moved half the skin, 0.3 r), once with
every bond intact (the usual state of a fracture run: the candidates are
bonded neighbours, excluded by their live bond) and once with every bond
broken (every neighbour pair touches).  Reported: the time per particle-step
of the contact forces (the compiled loops of
solver/partitions/contact_kernel.py; searches included), the share of it
spent building the search (the cell list and the candidates' bonds), and the
compiled bond loop's time per particle-step on the same lattice (diagonal
bonds, intact) for scale.

With ``--halo`` under mpiexec -n N the lattice is cut into N slabs, one per
rank, and each rank builds its contact halo (solver/partitions/halo.py) at
rest and after the jiggle, with particles of radius ``--radius`` spacings
(default 0.5: bonded neighbours just touch, and at rest every particle
within 2r + skin is a bond ghost already): reported per rank are its
particles, bond ghosts and halo particles (against the N - n particles an
all-gather would send it) and the time of one halo build (boxes, alltoallv,
trim; scipy imported before).
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from solver.partitions.bond_kernel import bond_forces
from solver.laws import CONTACT_LAWS, ContactSettings
from solver.partitions.contact import Contact


def lattice(n, a):
    g = np.arange(n) * a
    x, y = np.meshgrid(g, g, indexing="ij")
    pts = np.stack([x.ravel(), y.ravel()], axis=1)
    idx = np.arange(n * n).reshape(n, n)
    pairs = [(idx[:-1, :], idx[1:, :]), (idx[:, :-1], idx[:, 1:]),
             (idx[:-1, :-1], idx[1:, 1:]), (idx[1:, :-1], idx[:-1, 1:])]
    i = np.concatenate([p.ravel() for p, _ in pairs])
    j = np.concatenate([q.ravel() for _, q in pairs])
    return pts, i.astype(np.int64), j.astype(np.int64)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--halo", action="store_true", help="the halos of N slabs (under mpiexec)")
    ap.add_argument("--radius", type=float, default=0.5, help="--halo: radius [spacings]")
    args = ap.parse_args(argv)
    if args.halo:
        return halos(args.n, args.steps, args.radius)
    n, a = args.n, 1e-3
    pts, i, j = lattice(n, a)
    N = len(pts)
    rng = np.random.default_rng(1)
    rows = []
    warm = Contact(np.arange(N), ContactSettings(CONTACT_LAWS["linear"](1e7), 0.5 * a, 0.15 * a),
                   i, j)
    warm.forces(pts, np.ones(i.size, bool), np.zeros((N, 2)), N)   # loads the compiled loops
    for label, broken in (("bonds intact", 0.0), ("bonds all broken", 1.0)):
        settings = ContactSettings(CONTACT_LAWS["linear"](1e7), 0.5 * a, 0.15 * a, 0.0, 0.0, 0.5)
        contact = Contact(np.arange(N), settings, i, j)
        alive = np.arange(i.size) >= broken * i.size
        out = np.zeros((N, 2))
        x = pts.copy()
        v = 1e-3 * a * rng.standard_normal((N, 2))
        t_build = 0.0
        t0 = time.perf_counter()
        for _ in range(args.steps):
            x += v
            builds = contact.builds
            s = time.perf_counter()
            out[:] = 0.0
            contact.forces(x, alive, out, N)
            if contact.builds > builds:
                t_build += time.perf_counter() - s
        t = time.perf_counter() - t0
        rows.append((label, 1e9 * t / (N * args.steps), 100 * t_build / t, contact.builds))
    L0 = np.linalg.norm(pts[j] - pts[i], axis=1)
    k, alive = np.full(i.size, 1e7), np.ones(i.size, bool)
    limit, snapped = np.full(i.size, np.inf), np.zeros(i.size, np.int64)
    dX, u = pts[j] - pts[i], x - pts
    bond_forces(dX, u, i, j, k, L0, alive, limit, out, N, snapped, False)     # compile
    s = time.perf_counter()
    for _ in range(args.steps):
        bond_forces(dX, u, i, j, k, L0, alive, limit, out, N, snapped, False)
    t_bonds = time.perf_counter() - s
    print(f"square lattice {n} x {n} = {N} particles, {args.steps} steps")
    for label, per, share, builds in rows:
        print(f"  contact forces, {label}: {per:.1f} ns per particle-step ({builds} search "
              f"builds, {share:.0f} % of the time)")
    print(f"  compiled bond loop ({i.size} bonds): "
          f"{1e9 * t_bonds / (N * args.steps):.1f} ns per particle-step")


def halos(n, steps, radius):
    """The halo of each slab of an n x n lattice, one slab per rank, with
    particles of ``radius`` spacings."""
    from mpi4py import MPI
    import scipy.spatial  # noqa: F401 -- imported before the halo builds are timed
    from solver.partitions.halo import ContactHalo
    comm = MPI.COMM_WORLD
    a = 1e-3
    pts, i, j = lattice(n, a)
    slab = np.arange(n * n) // n * comm.size // n          # particles are numbered by column
    own = np.flatnonzero(slab == comm.rank)
    mine_i, mine_j = slab[i] == comm.rank, slab[j] == comm.rank
    ghosts = np.unique(np.concatenate([j[mine_i & ~mine_j], i[mine_j & ~mine_i]]))
    reach = (2 + 0.3) * radius * a                         # 2r + the default skin 0.3 r
    local = np.arange(own.size)
    halo = ContactHalo(comm, reach, local, local, own, own, pts[own], np.ones(own.size), ghosts)
    rng = np.random.default_rng(comm.rank)
    x = pts[own].copy()
    rows = []
    for label in ("at rest", f"after {steps} jiggled steps"):
        comm.Barrier()
        t0 = time.perf_counter()
        ids = halo.select(x)[0]
        t = time.perf_counter() - t0
        rows.append((label, ids.size, t))
        x += 1e-3 * a * rng.standard_normal((steps, *x.shape)).sum(axis=0)
    table = comm.gather((own.size, ghosts.size, rows), root=0)
    if comm.rank == 0:
        print(f"square lattice {n} x {n} = {n * n} particles in {comm.size} slabs, "
              f"reach 2r + skin = {reach / a:g} a")
        for r, (n_own, n_ghost, rows) in enumerate(table):
            line = ", ".join(f"{label}: halo {size} ({1e3 * t:.2f} ms)" for label, size, t in rows)
            print(f"  rank {r}: {n_own} particles, {n_ghost} bond ghosts, {line}; an all-gather: "
                  f"{n * n - n_own}")


if __name__ == "__main__":
    main()
