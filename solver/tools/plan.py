"""Before anything runs: the predicted cost of a scene's speed-ups side by side.

    ./run.sh plan SCENE.yaml [--set key=value ...] [--scaling 1.5,2,4]

For the scene's model (a continuum or a network that ``partitions: auto`` can
level) the candidates are

- uniform explicit: one step for every element, time.safety x the whole
  model's critical step (Lanczos);
- automatic levels: the scene's ``time.levels`` (``partitions: auto``,
  ``time.dt: auto``), its level table;
- each with mass scaling to ``--scaling`` x the smallest element bound.

Each line gives the base step, the levels, the added mass and the predicted
wall per simulated second on this machine, from a per-nonzero MatMult cost
and a per-DOF vector cost measured here on the model's own operator (a
fraction of a second).  What the prediction leaves out: set-up, output,
load application, the exchange of a run on several ranks.  What each changes:
levels change nothing physical (each level runs at a stable step of its
own; the error is the time discretisation's at the coarser steps), mass
scaling changes the inertia of the scaled elements (the added mass is
printed).  An implicit coarse level is not a candidate yet.
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import time

import numpy as np
from scipy.sparse import coo_matrix

from solver.errors import SceneError, SolverError
from solver.model import arrays, binding, element_bounds
from solver.model.arrays import dof_masses
from solver.model.cell_blocks import kept
from solver.partitions import levels as lv
from solver.partitions.assembly import triplets
from solver.petscutil import init
from solver.scene.sections import MassScaling

VECTOR_PASSES = {"uniform": 3, "levels": 2}      # vector sweeps per fine step besides MatMults


def measure(mdl, repeat: int = 20):
    """(seconds per stored nonzero of a MatMult, seconds per DOF of a vector
    update) of this machine on the model's whole stiffness (PETSc AIJ)."""

    P = init()
    rows, cols, vals = triplets(mdl.stiffness_blocks(np.arange(mdl.n_nodes)), mdl.dofmap)
    n = mdl.n_dofs
    A = coo_matrix((vals, (rows, cols)), shape=(n, n)).tocsr()
    A.sum_duplicates()
    M = P.Mat().createAIJ((n, n), csr=(A.indptr.astype(P.IntType), A.indices.astype(P.IntType),
                                        A.data), comm=P.COMM_SELF)
    x, y = M.createVecs()
    x.set(1.0)
    best_mat = best_vec = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        for _ in range(repeat):
            M.mult(x, y)
        best_mat = min(best_mat, (time.perf_counter() - t0) / repeat)
        t0 = time.perf_counter()
        for _ in range(repeat):
            y.axpy(1e-30, x)
        best_vec = min(best_vec, (time.perf_counter() - t0) / repeat)
    nnz = A.nnz
    for obj in (M, x, y):
        obj.destroy()
    return best_mat / max(nnz, 1), best_vec / max(n, 1), nnz


def level_nonzeros(mdl, bounds, per_block, ratios):
    """Assembled nonzeros of each level's operator."""

    n = mdl.n_dofs
    out = {}
    for r in ratios:
        blocks = [kept(c, K, rs == r) for (c, K), rs in zip(lv.model_blocks(mdl), per_block)
                  if (rs == r).any()]
        rows, cols, vals = triplets(blocks, mdl.dofmap)
        A = coo_matrix((np.ones_like(vals), (rows, cols)), shape=(n, n)).tocsr()
        A.sum_duplicates()
        out[r] = A.nnz
    return out


def candidates(scene, mdl, factors):
    """[(name, dt, ratios, nonzeros per level, added mass fraction, note)]."""
    t = scene.time
    out = []
    if mdl.kind != "continuum":
        factors = []                  # mass scaling adds element masses: continua only
    for f in [None, *factors]:
        m = mdl
        bounds = element_bounds.model_bounds(scene, m)
        added = 0.0
        if f is not None:
            target = f * min(float(b.steps.min()) for b in bounds)
            every = MassScaling(target, max_added=float("inf"))    # plan shows every target
            spec = dataclasses.replace(scene.time, mass_scaling=every)
            scaling, m = lv.scale_mass(dataclasses.replace(scene, time=spec), m, bounds)
            added = scaling.fraction
        mass = dof_masses(m, np.arange(m.n_nodes))
        one = [np.ones(b.steps.size, int) for b in bounds]
        omega = lv.level_omega(m, bounds, one, 1, mass)
        if omega <= 0:
            raise SceneError("plan: the model has no stiffness on its free DOFs: nothing to "
                             "step")
        h_u = t.safety * 2.0 / omega
        tag = "" if f is None else f" + mass scaling to {f:g} x the smallest bound"
        out.append((f"uniform explicit{tag}", h_u, [1], level_nonzeros(m, bounds, one, [1]), added))
        ratios = lv.allowed(t.levels.max_ratio, t.levels.ratios)
        # the scene's own step when it gives one (mass scaling: the larger auto step)
        h = lv.auto_dt(scene, m, bounds, ratios, mass, []) if t.dt == "auto" or f else t.dt
        per = lv.assign(bounds, h, ratios, t.safety, t.levels.buffer)
        present = sorted({int(r) for rs in per for r in np.unique(rs)})
        out.append((f"automatic levels{tag}", h, present,
                    level_nonzeros(m, bounds, per, present), added))
    return out


def predict(dt, ratios, nnz, c_nz, c_vec, n_dofs):
    """Predicted wall [s] per simulated second."""
    R = max(ratios)
    passes = VECTOR_PASSES["uniform" if R == 1 else "levels"]
    per_system = sum(nnz[r] * (R // r) for r in ratios) * c_nz + \
        R * n_dofs * c_vec * (passes + len(ratios))
    return per_system / (R * dt)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="./run.sh plan", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("--scaling", default="1.5,2,4",
                    help="mass-scaling targets as multiples of the smallest element bound")
    ap.add_argument("--set", action="append", default=[], dest="sets")
    args = ap.parse_args(argv)
    try:
        factors = [float(x) for x in args.scaling.split(",") if x.strip()]
        if any(f <= 1 for f in factors):
            raise SceneError(f"--scaling {args.scaling}: multiples above 1 of the smallest bound")
        init([])
        scene = binding.load(args.scene, args.sets)
        if scene.model.kind == "continuum" and scene.model.lattice is not None:
            raise SceneError("model.lattice: plan predicts the levels of a continuum's or a "
                             "network's elements; a lattice's fem and dem partitions are "
                             "hand-written (their steps and costs are in the run's log)")
        if scene.partitions != "auto":
            scene = dataclasses.replace(scene, partitions="auto")
        scene = binding.bind(scene)
        mdl = arrays.build(scene)
        rows = candidates(scene, mdl, factors)
        c_nz, c_vec, _ = measure(mdl)
    except SolverError as e:
        print(f"error: {e}", file=sys.stderr)
        return e.exit_code
    except ValueError as e:
        print(f"error: --scaling {args.scaling}: {e}", file=sys.stderr)
        return 2
    n = mdl.n_dofs
    print(f"[plan] {scene.name}: {n} DOFs; measured here: {c_nz * 1e9:.3g} ns per MatMult "
          f"nonzero, {c_vec * 1e9:.3g} ns per DOF of a vector update")
    base = None
    print(f"| candidate | dt [s] | levels | added mass | predicted wall per simulated s | "
          f"vs uniform |\n|---|---|---|---|---|---|")
    for name, dt, ratios, nnz, added in rows:
        wall = predict(dt, ratios, nnz, c_nz, c_vec, n)
        base = base or wall
        print(f"| {name} | {dt:.4g} | {', '.join(map(str, ratios))} | {100 * added:.3g} % | "
              f"{wall:.4g} s | {wall / base:.3f} |")
    print("[plan] levels change no physics (each level at a stable step of its own); mass "
          "scaling adds the inertia shown; an implicit coarse level is not a candidate yet")
    return 0


if __name__ == "__main__":
    sys.exit(main())
