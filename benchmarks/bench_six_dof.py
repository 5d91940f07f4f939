"""Cost of a fine step on the six-DOF scene (1 rank), as ratios in one run.

    ./run.sh bench            (or: python benchmarks/bench_six_dof.py [--eta 1] [--end 20])

Reports the stepping wall time of the whole run, microseconds per fine (DEM)
step and per system step, the split between partitions and the exchange, and
the ratio against two floors measured in the same process: a bare monolithic
velocity-Verlet loop over the same chain in numpy (what any Python driver
pays per step), and the same loop driven through petsc4py Vec/Mat calls.
Target of the foundation issue: the 20 s run at eta = 1 in under 5 s wall.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from solver.model import arrays as model_mod
from solver import scene as scene_mod
from solver.model import binding
from solver.petscutil import aij, init, vec_on

ROOT = Path(__file__).resolve().parents[1]


def numpy_floor(K, m, f_node, omega, dt, n):
    """Monolithic velocity Verlet in numpy: the cheapest honest Python loop."""
    u = np.zeros(m.size)
    v = np.zeros(m.size)
    a = np.zeros(m.size)
    minv = 1.0 / m
    t0 = time.perf_counter()
    for k in range(1, n + 1):
        u += dt * v + (0.5 * dt * dt) * a
        v += (0.5 * dt) * a
        r = -(K @ u)
        r[f_node] += np.sin(omega * k * dt)
        a = r * minv
        v += (0.5 * dt) * a
    return time.perf_counter() - t0


def petsc_floor(rows, cols, vals, m, f_node, omega, dt, n):
    """The same loop through petsc4py calls (the calls one step needs at least)."""
    P = init()
    U, V, A, R = (np.zeros(m.size) for _ in range(4))
    u, v, a, r = (vec_on(x, P.COMM_SELF) for x in (U, V, A, R))
    minv = vec_on(1.0 / m, P.COMM_SELF)
    K = aij(rows, cols, vals, m.size, P.COMM_SELF, "floor_", scale=-1.0)
    t0 = time.perf_counter()
    for k in range(1, n + 1):
        u.axpy(dt, v)
        u.axpy(0.5 * dt * dt, a)
        v.axpy(0.5 * dt, a)
        K.mult(u, r)
        R[f_node] += np.sin(omega * k * dt)
        a.pointwiseMult(r, minv)
        v.axpy(0.5 * dt, a)
    return time.perf_counter() - t0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--eta", type=int, default=1)
    ap.add_argument("--end", type=float, default=20.0)
    args = ap.parse_args(argv)
    init([])
    from mpi4py import MPI

    from solver.driver.runner import run
    scene = binding.load(ROOT / "configs/six_dof.yaml",
                           [f"partitions.fem.ratio={args.eta}", f"time.end={args.end}",
                            "output.file=results/bench_six_dof.h5", "output.progress=0"])
    res = run(scene, MPI.COMM_SELF, log=lambda *a: None)
    a = res.attrs
    fine = res.partitions["dem"]["steps"]
    n_sys = a["n_system_steps"]
    wall = a["stepping_wall_time"]
    mdl = model_mod.build(scene)
    K = mdl.full_stiffness()
    omega = scene.loads[0].omega
    t_np = numpy_floor(K, mdl.mass, 1, omega, scene.time.dt, fine)
    rows, cols, vals = mdl.stiffness_triplets(np.arange(mdl.n_nodes))
    t_petsc = petsc_floor(rows, cols, vals, mdl.mass, 1, omega, scene.time.dt, fine)
    print(f"six_dof, eta = {args.eta}, {args.end:g} s, 1 rank: {n_sys} system steps, {fine} fine steps")
    print(f"  stepping wall          {wall:8.3f} s   (whole run incl. set-up {a['wall_time']:.3f} s; "
          f"target < 5 s at eta = 1, 20 s)")
    print(f"  per fine step          {1e6 * wall / fine:8.2f} us")
    print(f"  per system step        {1e6 * wall / n_sys:8.2f} us")
    for name, p in res.partitions.items():
        print(f"    {name:5s} advance      {1e6 * p['wall_time'] / n_sys:8.2f} us per system step "
              f"({p['steps'] // n_sys} step(s) of {p['dt']:.1e} s)")
    print(f"    exchange           {1e6 * a['exchange_wall_time'] / n_sys:8.2f} us per system step")
    print(f"  floor: monolithic Verlet, numpy     {1e6 * t_np / fine:8.2f} us/step -> ours / floor = "
          f"{wall / t_np:.2f}")
    print(f"  floor: monolithic Verlet, petsc4py  {1e6 * t_petsc / fine:8.2f} us/step -> ours / floor = "
          f"{wall / t_petsc:.2f}")


if __name__ == "__main__":
    main()
