"""Granular contacts with shear history against LAMMPS, side by side (1 core).

    python benchmarks/bench_granular.py [--n 58] [--packing poisson|jittered]
                                        [--steps 400] [--lmp PATH]

The case: spheres of diameter 1 and mass 1 in a random packing with random
velocities (seeded): a Poisson-disc packing of a cube of side n (Bridson's
sampling, solver/model/packing.py: no two centres closer than 0.9, so neighbours 0.9 to 1 apart
touch with random overlaps; n = 50: 103k spheres), or (``--packing
jittered``) an n^3 simple-cubic grid of spacing 0.95 with every sphere moved
by a uniform jitter of +-0.04.  Hooke contacts with shear history and Coulomb sliding,
no dashpots: k_n = 2e5, k_t = 2/7 k_n, mu = 0.5; neighbour skin 0.15 (0.3 r),
rebuilt when a sphere has moved half of it; NVE, h = 0.02 / sqrt(k_n).

- ours: the contact forces of a dem partition (solver/partitions/contact.py,
  friction_model history), stepped with velocity Verlet on PETSc Vecs as
  the partition steps, through the compiled loops
  (solver/partitions/contact_kernel.py) and through the numpy path they are
  tested against;
- LAMMPS: ``pair_style gran/hooke/history 2e5 NULL 0 NULL 0.5 0`` (the same
  law: k_t = 2/7 k_n by default, no damping), ``fix nve`` (the spheres do
  not rotate: ours turn only with beam bonds; LAMMPS still computes the
  torques), the same positions and velocities from a data file.

Reported: atom-steps/s and ns per candidate pair of each, their ratios to
LAMMPS, and the kinetic energy after the run by both (the same physics:
they agree to the differences in how the shear history is advanced).  LAMMPS
is not installed by run.sh; ``benchmarks/lammps_unpacked.sh`` unpacks
Debian's package into a directory without touching the system and prints
the ``--lmp`` wrapper to pass.  Without LAMMPS only our rows are printed.
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

from solver.laws import CONTACT_LAWS, ContactSettings
from solver.model.packing import poisson_disc
from solver.partitions.contact import Contact
from solver.petscutil import init, vec_on

KN, MU, RADIUS = 2e5, 0.5, 0.5


def packing(n, seed=1, kind="poisson"):
    """Positions and velocities (seeded) of the spheres: ``poisson``, a
    Poisson-disc packing of a cube of side n (no two centres closer than
    0.9, about 0.55 n^3 spheres); ``jittered``, the n^3 jittered grid."""
    rng = np.random.default_rng(seed)
    if kind == "poisson":
        X = poisson_disc(np.zeros(3), np.full(3, float(n)), 0.45, 0.0, seed)[0]
    else:
        g = np.arange(n) * 0.95
        X = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
        X += rng.uniform(-0.04, 0.04, X.shape)
    return X, rng.normal(0.0, 0.02, X.shape)


def step_size():
    return 0.02 / np.sqrt(KN)


def ours(X, V, steps, compiled=True):
    """(atom-steps/s, ns per candidate pair, candidate pairs, kinetic energy at
    the end, contacts at the start and at the end, search builds) from
    positions X and velocities V."""
    P = init([])
    N = len(X)
    settings = ContactSettings(CONTACT_LAWS["linear"](KN), RADIUS, 0.3 * RADIUS, 0.0, MU, 0.0,
                               history=True)
    h = step_size()
    contact = Contact(np.arange(N), settings, np.zeros(0, np.int64), np.zeros(0, np.int64),
                      np.ones(N), dt=h, compiled=compiled)
    arrs = [X.ravel().copy(), V.ravel().copy(), np.zeros(3 * N)]
    x, v, a = (vec_on(arr, P.COMM_SELF) for arr in arrs)
    pos = arrs[0].reshape(N, 3)
    alive = np.zeros(0, bool)

    def accelerate():                     # unit masses: a = f
        out = a.getArray().reshape(N, 3)  # (a writable view: PETSc sees the change)
        out[:] = 0.0
        contact.forces(pos, alive, out, N)

    accelerate()                          # compiles the loops (cached on disk), builds
    start = len(contact.touching()[0])
    pairs = 0
    t0 = time.perf_counter()
    for _ in range(steps):                # as solver/partitions/integrators.py steps
        x.maxpy((h, 0.5 * h * h), (v, a))
        v.axpy(0.5 * h, a)
        accelerate()
        v.axpy(0.5 * h, a)
        pairs += len(contact._pairs)
    t = (time.perf_counter() - t0) / steps
    kinetic = 0.5 * float(np.dot(arrs[1], arrs[1]))
    return (N / t, 1e9 * t * steps / pairs, pairs // steps, kinetic, start,
            len(contact.touching()[0]), contact.builds)


LAMMPS_INPUT = """units lj
atom_style sphere
boundary s s s
comm_modify vel yes
read_data data.pack
pair_style gran/hooke/history {kn!r} NULL 0 NULL {mu!r} 0
pair_coeff * *
neighbor {skin!r} bin
neigh_modify delay 0 every 1 check yes
fix 1 all nve
timestep {h!r}
thermo_style custom step ke
thermo_modify norm no format float %.15g
thermo {steps}
run {steps}
"""


def lammps(X, V, steps, exe):
    """(atom-steps/s, ns per neighbour pair, pairs, kinetic energy at the end)
    of LAMMPS on the same packing, or None without it."""
    exe = exe or shutil.which("lmp")
    if not exe:
        return None
    tmp = Path(tempfile.mkdtemp())
    lo, hi = (X.min(axis=0) - 1.0).tolist(), (X.max(axis=0) + 1.0).tolist()
    density = float(1.0 / (4.0 / 3.0 * np.pi * RADIUS ** 3))     # mass 1
    with open(tmp / "data.pack", "w") as out:
        out.write(f"packing\n\n{len(X)} atoms\n1 atom types\n\n")
        for c, axis in enumerate("xyz"):
            out.write(f"{lo[c]!r} {hi[c]!r} {axis}lo {axis}hi\n")
        out.write("\nAtoms # sphere\n\n")
        out.writelines(f"{k + 1} 1 {2 * RADIUS!r} {density!r} {p[0]!r} {p[1]!r} {p[2]!r}\n"
                       for k, p in enumerate(X.tolist()))
        out.write("\nVelocities\n\n")
        out.writelines(f"{k + 1} {w[0]!r} {w[1]!r} {w[2]!r} 0 0 0\n"
                       for k, w in enumerate(V.tolist()))
    (tmp / "in.gran").write_text(LAMMPS_INPUT.format(kn=KN, mu=MU, skin=0.3 * RADIUS,
                                                      h=float(step_size()), steps=steps))
    out = subprocess.run([exe, "-in", "in.gran", "-log", "none"], cwd=tmp, capture_output=True,
                         text=True, env={**os.environ, "OMP_NUM_THREADS": "1"})
    m = re.search(r"Loop time of ([\d.eE+-]+) on 1 procs for (\d+) steps with (\d+) atoms",
                  out.stdout)
    if not m:
        raise SystemExit(f"LAMMPS did not report a loop time:\n{out.stdout[-1500:]}"
                         f"{out.stderr[-1500:]}")
    t, s, atoms = float(m.group(1)), int(m.group(2)), int(m.group(3))
    pairs = int(re.search(r"Total # of neighbors = (\d+)", out.stdout).group(1))
    kinetic = float(re.findall(rf"^\s*{s}\s+([\d.eE+-]+)\s*$", out.stdout, re.M)[-1])
    return atoms * s / t, 1e9 * t / s / pairs, pairs, kinetic


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=50, help="the packing's side (poisson) or spheres "
                    "per axis (jittered)")
    ap.add_argument("--packing", choices=("poisson", "jittered"), default="poisson")
    ap.add_argument("--steps", type=int, default=400)
    ap.add_argument("--lmp", default=os.environ.get("LMP"), help="the LAMMPS executable "
                    "(default: $LMP, else lmp on PATH)")
    args = ap.parse_args(argv)
    X, V = packing(args.n, kind=args.packing)
    fast = ours(X, V, args.steps)
    slow = ours(X, V, args.steps, compiled=False)
    what = (f"Poisson-disc packing of a cube of side {args.n} (centres >= 0.9 apart)"
            if args.packing == "poisson" else f"jittered grid {args.n}^3")
    print(f"{what}: {len(X)} spheres of diameter 1, gran/hooke/history, {args.steps} steps")
    for label, row in (("ours, compiled loops", fast), ("ours, numpy reference", slow)):
        rate, per_pair, pairs, _, start, end, builds = row
        print(f"  {label:28s} {rate / 1e6:6.2f} M atom-steps/s, {per_pair:6.2f} ns per candidate "
              f"pair ({pairs} pairs; {start} touching at the start, {end} at the end; {builds} "
              "builds)")
    print(f"  compiled / numpy throughput = {fast[0] / slow[0]:.2f}")
    lmp = lammps(X, V, args.steps, args.lmp)
    if lmp is None:
        print("  LAMMPS: not found (benchmarks/lammps_unpacked.sh unpacks it; pass --lmp)")
        return
    print(f"  {'LAMMPS gran/hooke/history':28s} {lmp[0] / 1e6:6.2f} M atom-steps/s, "
          f"{lmp[1]:6.2f} ns per neighbour pair ({lmp[2]} pairs)")
    print(f"  ours, compiled / LAMMPS throughput = {fast[0] / lmp[0]:.2f}")
    print(f"  kinetic energy after {args.steps} steps: ours {fast[3]:.9g}, LAMMPS {lmp[3]:.9g} "
          f"(relative difference {abs(fast[3] - lmp[3]) / lmp[3]:.1e})")


if __name__ == "__main__":
    main()
