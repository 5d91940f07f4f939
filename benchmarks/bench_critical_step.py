"""Tightness and set-up time of the critical-step estimate (solver/partitions/stability.py).

    python benchmarks/bench_critical_step.py [--big 47] [--sizes 10,18,25] [--no-arpack-big]

For every case, omega_max^2 = lambda_max(M^-1/2 K M^-1/2) of the partition's
operator (lumped mass, held DOFs dropped) by

- the truth: ARPACK (scipy eigsh, tol 1e-13) on the sparse matrix;
- the guard's Lanczos before PETSc (stability.omega_max, rank 0) and on the
  assembled PETSc operator (stability.from_operator, MatMult);
- the Gershgorin bound of the assembled operator (stability.gershgorin);
- the former estimate: ARPACK at tol 1e-10, ncv 40, raised by 1e-6 (what the
  guard ran up to 300,000 DOF).

Cases: structured hex blocks (meshes/block3d.geo, one face fixed) of
``--sizes`` cells per side, the configs' meshes (bar3d: tetrahedra and
hexahedra; plate_shell: shells with rotary inertia; metamaterial: a bonded
lattice with its overlap cells; wave_bar_transition: the FE side with band
masses and carried bonds, core particles held), and a ``--big`` block (47:
331,776 DOF) for the set-up time, whose truth is the former ARPACK unless
--no-arpack-big.  Estimate / truth - 1 is printed for omega (not omega^2).
Timings are wall seconds on this machine (one process).  Writes
docs/bench_critical_step.md.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_setup import SCENE, make_mesh  # noqa: E402  (the block mesh and its scene)


def operator(scene, p=0):
    """(blocks, held, mass with inf on held-still DOFs, dofmap, model) of partition ``p``."""
    from solver.coupling import overlap
    from solver.model import arrays
    from solver.coupling.schemes import scheme_class
    from solver.model.arrays import dof_masses
    from solver.partitions import stability
    treatments = scheme_class(scene.coupling.scheme).treatments(scene)
    layers = overlap.layer_counts(scene.partitions, treatments)
    mdl = arrays.build(scene, layers)
    lay = overlap.derive(mdl.graph(), scene.partitions, layers)[p]
    spec = scene.partitions[p]
    held = lay.held
    dm = mdl.dofmap
    blocks = mdl.bond_blocks(held) if spec.method == "dem" else mdl.stiffness_blocks(held)
    still = mdl.fixed[dm.dofs(held)]
    if stability.coupled_fe(scene, spec):
        still = still | (np.arange(still.size) >= dm.count(held[:lay.n_owned]))
    mass = np.where(still, np.inf, dof_masses(mdl, held))
    return blocks, held, mass, dm, mdl


def scaled_csr(blocks, held, mass, dm):
    from scipy.sparse import coo_matrix
    from solver.model.dofmap import DofMap
    from solver.partitions.assembly import triplets
    local = np.full(int(held.max()) + 1, -1, dtype=np.int64)
    local[held] = np.arange(held.size)
    r, c, v = triplets([(local[cc], k) for cc, k in blocks], DofMap(dm.counts[held]))
    s = np.where(np.isfinite(mass), 1.0 / np.sqrt(np.where(np.isfinite(mass), mass, 1.0)), 0.0)
    n = mass.size
    return coo_matrix((v * s[r] * s[c], (r, c)), shape=(n, n)).tocsr()


def arpack(A, tol):
    from scipy.sparse.linalg import eigsh
    n = A.shape[0]
    return float(eigsh(A, k=1, which="LA", tol=tol, ncv=min(n - 1, 40),
                       v0=np.random.default_rng(0).standard_normal(n), maxiter=20 * n,
                       return_eigenvectors=False)[0])


def clock(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


def measure(label, scene, p=0, truth=True):
    from solver.partitions import stability
    from solver.partitions.assembly import default_type, matrix
    from solver.petscutil import init
    P = init([])
    blocks, held, mass, dm, mdl = operator(scene, p)
    n = mass.size
    A, t_csr = clock(lambda: scaled_csr(blocks, held, mass, dm))
    old, t_old = clock(lambda: np.sqrt(arpack(A, 1e-10)) * (1 + 1e-6)) if truth else (None, None)
    true = np.sqrt(arpack(A, 1e-13)) if truth == "tight" or (truth and n <= 60000) else old
    limit = stability.PREBUILD_LIMIT
    stability.PREBUILD_LIMIT = 10 ** 9
    try:
        pre, t_pre = clock(lambda: stability.omega_max(blocks, held, mass, dm, label))
    finally:
        stability.PREBUILD_LIMIT = limit
    number = np.full(mdl.n_nodes, -1, dtype=np.int64)
    number[held] = np.arange(held.size)
    Kneg, t_asm = clock(lambda: matrix(lambda: blocks, number, held.size, held.size, 0, dm,
                                       P.COMM_SELF, "bench_", scale=-1.0,
                                       mat_type=default_type(dm.block)))
    still = ~np.isfinite(mass)
    ids = dm.dofs(held)
    asm, t_lan = clock(lambda: stability.from_operator(Kneg, np.where(still, 1.0, mass), still,
                                                      ids, label))
    ger, t_ger = clock(lambda: stability.gershgorin(Kneg, np.where(still, 1.0, mass), still))
    Kneg.destroy()
    ref = true if true is not None else asm.omega_max
    return {"case": label, "dof": n, "true": true, "pre": pre.omega_max / ref - 1,
            "asm": asm.omega_max / ref - 1, "method": asm.method,
            "ger": ger.omega_max / ref - 1, "old": (old / ref - 1) if old else None,
            "t_pre": t_pre, "t_lan": t_lan, "t_ger": t_ger, "t_old": t_old, "t_asm": t_asm,
            "t_csr": t_csr}


def block_scene(n, tmp):
    from solver import scene as scene_mod
    mesh = Path(tmp) / f"block{n}.msh"
    make_mesh(n, str(mesh))
    path = Path(tmp) / f"block{n}.yaml"
    path.write_text(SCENE.format(end=1e-8, mesh=mesh, out=Path(tmp) / "o.h5"))
    return scene_mod.load(path)


def config(name, **sets):
    from solver import scene as scene_mod
    return scene_mod.load(ROOT / "configs" / f"{name}.yaml", [f"{k}={v}" for k, v in sets.items()])


def fmt(x, spec="+.1e"):
    return "-" if x is None else format(x, spec)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="10,18,25", help="cells per side of the hex blocks")
    ap.add_argument("--big", type=int, default=47, help="cells per side of the set-up case (0: none)")
    ap.add_argument("--no-arpack-big", action="store_true", help="skip ARPACK on the big block")
    ap.add_argument("--no-configs", action="store_true", help="skip the configs' meshes")
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        if not args.no_configs:
            for label, name, p, sets in [
                    ("bar3d (tets + hexes)", "bar3d", 0, {}),
                    ("plate_shell (shells, rotary inertia)", "plate_shell", 0, {}),
                    ("metamaterial fem", "metamaterial", 0, {}),
                    ("metamaterial dem (bonds + overlap cells)", "metamaterial", 1, {}),
                    ("wave_bar_transition fem (band, core held)", "wave_bar_transition", 0, {})]:
                rows.append(measure(label, config(name, **sets), p))
                print(rows[-1], flush=True)
        for n in [int(s) for s in args.sizes.split(",") if s]:
            rows.append(measure(f"hex block {n}^3", block_scene(n, tmp)))
            print(rows[-1], flush=True)
        if args.big:
            rows.append(measure(f"hex block {args.big}^3", block_scene(args.big, tmp),
                                truth=not args.no_arpack_big))
            print(rows[-1], flush=True)
    lines = ["# Critical step: tightness and set-up time", "",
             "`python benchmarks/bench_critical_step.py` (one process). omega_max of",
             "M^-1/2 K M^-1/2 for each partition operator; columns: estimate / true - 1",
             "(true: ARPACK at tol 1e-13; for the largest block the former ARPACK estimate),",
             "and wall seconds of each estimate alone (assembly excluded).", "",
             "| case | DOF | true omega_max [rad/s] | Lanczos before PETSc | Lanczos on PETSc "
             "operator | Gershgorin | former ARPACK | Lanczos PETSc [s] | Lanczos numpy [s] | "
             "Gershgorin [s] | former ARPACK [s] |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['case']} | {r['dof']} | {fmt(r['true'], '.6e')} | {fmt(r['pre'])} | "
                     f"{fmt(r['asm'])} ({r['method']}) | {fmt(r['ger'])} | {fmt(r['old'])} | "
                     f"{r['t_lan']:.3g} | {r['t_pre']:.3g} | {r['t_ger']:.3g} | "
                     f"{fmt(r['t_old'], '.3g')} |")
    text = "\n".join(lines) + "\n"
    (ROOT / "docs" / "bench_critical_step.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
