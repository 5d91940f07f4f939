"""Set-up memory and time on 1, 2 and 4 ranks: does any rank hold the whole model?

    python benchmarks/bench_memory.py [--a 4e-4] [--T 0.032] [--steps 10] [--ranks 1,2,4] [--pairs 3]

The scene is benchmarks/bench_scaling.py's coupled bar (configs/bar3d.yaml, 12 cm
long, 12 mm high, 0.4 mm cubes, a bonded DEM block in the middle) made twice as
thick, T = 32 mm: 2.27 M DOF.  Each rank count runs the solver as a user would
(``mpiexec -n N python -m solver``, a few explicit steps) and reads from its
output every rank's peak resident memory (VmHWM, gathered to rank 0)
and the set-up wall time (the run's own clock: from the bound scene, its mesh
read, to the first step), and times the whole process (launch to exit: the
mesh generation and the 10 steps included).  Set-up times on this shared
machine move by 10-30 % between runs, so the 2-rank/1-rank ratio is taken
over ``--pairs`` runs of 1 then 2 ranks in turn (the memory runs are the
first pair) and given as the median pair with the range.  The issue's
targets (issue 23):

* the largest rank <= 1.3 x the median rank + 100 MB,
* the sum over the ranks <= 1.3 x the 1-rank peak,
* set-up on 2 ranks <= 0.7 x set-up on 1 rank.

4 ranks oversubscribe a 2-core machine: its memory counts, its times do not.
Writes docs/benchmarks/bench_memory.md (benchmarks/tables.py).
"""
from __future__ import annotations

import argparse
import dataclasses
import pickle
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import tables                                    # noqa: E402  (benchmarks/tables.py)
from bench_scaling import SCENE, overrides, read_extra  # noqa: E402  (the same bar, the same attrs)
from solver.tools.sweep import run_one           # noqa: E402

LARGEST, PLUS_MB, SUM, SETUP = 1.3, 100.0, 1.3, 0.7      # the issue's targets
DEFAULT = {"a": 4e-4, "T": 0.032, "ranks": "1,2,4"}


def sets(a, T, steps) -> list[str]:
    """bench_scaling's bar at cube size ``a`` and thickness ``T`` (the lattice on the mesh)."""
    return overrides(a, steps, T=T) + [f"model.lattice.spacing={a}"]


def measure(a, T, steps, ranks, tmp) -> dict:
    """Peak RSS per rank [MB], set-up and whole-process wall [s] and DOF of one
    run on ``ranks`` ranks."""
    out = tmp / f"memory_{ranks}.h5"
    t0 = time.perf_counter()
    run_one(SCENE, ranks, sets(a, T, steps), out)
    wall = time.perf_counter() - t0
    r = read_extra(out)
    return {"ranks": ranks, "rss": r["rss"], "setup": r["setup"], "wall": wall, "dof": r["dof"]}


def ratios(pairs) -> dict:
    """Median and range of the 2-rank / 1-rank ratios of (one, two) run pairs,
    for the set-up and the whole process."""
    out = {}
    for key in ("setup", "wall"):
        r = np.array([two[key] / one[key] for one, two in pairs])
        out[key] = (float(np.median(r)), float(r.min()), float(r.max()), r)
    return out


def verdict(ok: bool) -> str:
    return "yes" if ok else "**no**"


def lines_for(runs, a, T, steps, pairs=()) -> list[str]:
    one = runs[0]
    peak1, setup1 = float(one["rss"].max()), one["setup"]
    lines = [f"# Set-up memory: coupled bar, {one['dof']:,} DOF (FEM + bonded DEM lattice), "
             f"1 to {runs[-1]['ranks']} ranks", "",
             f"`python benchmarks/bench_memory.py` (run by `./run.sh bench`): configs/bar3d.yaml "
             f"at 12 cm x 12 mm x {1e3 * T:g} mm, cubes of {1e3 * a:g} mm, {steps} explicit "
             "steps. Peak RSS is each process's own high-water mark (VmHWM); set-up is the run's own "
             "wall time from the bound scene (its mesh read) to the first step; process is launch to "
             "exit (mesh generation, 10 steps and output included).", "",
             "| ranks | set-up [s] | set-up / 1 rank | process [s] | peak RSS per rank [MB] | largest / median "
             f"| largest <= {LARGEST} x median + {PLUS_MB:.0f} MB | sum [MB] | sum / 1-rank peak "
             f"| sum <= {SUM} x 1-rank peak |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in runs:
        rss = r["rss"]
        big, med, tot = float(rss.max()), float(np.median(rss)), float(rss.sum())
        lines.append(f"| {r['ranks']} | {r['setup']:.1f} | {r['setup'] / setup1:.2f} | "
                     f"{r['wall']:.1f} | "
                     f"{' / '.join(f'{x:.0f}' for x in rss)} | {big / med:.2f} | "
                     f"{verdict(big <= LARGEST * med + PLUS_MB)} | {tot:.0f} | {tot / peak1:.2f} | "
                     f"{verdict(tot <= SUM * peak1)} |")
    if pairs:
        rs = ratios(pairs)
        med, lo, hi, each = rs["setup"]
        singles = ", ".join(f"{one['setup']:.1f}" for one, _ in pairs)
        lines += ["", f"- **Set-up, 2 ranks / 1 rank: {med:.2f}**, the median of {len(pairs)} pairs "
                  f"of runs in turn ({lo:.2f}-{hi:.2f}: {', '.join(f'{x:.2f}' for x in each)}; "
                  f"target <= {SETUP}: {'met' if med <= SETUP else 'not met'}; the 1-rank set-ups "
                  f"{singles} s).",
                  f"- Whole process, 2 ranks / 1 rank (the serial mesh generation included): "
                  f"{rs['wall'][0]:.2f} ({rs['wall'][1]:.2f}-{rs['wall'][2]:.2f})."]
    worst = max(runs, key=lambda r: r["rss"].max() / np.median(r["rss"]))
    lines += [f"- **Largest rank / median rank: {worst['rss'].max() / np.median(worst['rss']):.2f}** "
              f"on {worst['ranks']} ranks (rank {int(np.argmax(worst['rss']))} at "
              f"{worst['rss'].max():.0f} MB).",
              "- Memory is each process's own peak, whatever else runs on the machine; the "
              "set-up times come from a shared 2-core machine (4 ranks oversubscribe it), so "
              "their ratios are indications, not final figures."]
    return lines


def footprint(obj, seen=None) -> int:
    """Bytes of the numpy arrays reachable from ``obj`` (each array once): through
    containers, dataclasses and plain objects' attributes."""
    seen = set() if seen is None else seen
    if id(obj) in seen or isinstance(obj, (str, bytes, int, float, bool, type(None), type)):
        return 0
    seen.add(id(obj))
    if isinstance(obj, np.ndarray):
        return obj.nbytes
    if isinstance(obj, dict):
        items = obj.values()
    elif isinstance(obj, (list, tuple, set, frozenset)):
        items = obj
    elif dataclasses.is_dataclass(obj):
        items = [obj.__dict__.get(f.name) for f in dataclasses.fields(obj)]
    elif hasattr(obj, "__dict__") and not callable(obj):
        items = vars(obj).values()
    else:
        return 0
    return sum(footprint(x, seen) for x in items)


def rss_mb() -> tuple[float, float]:
    """(resident now, peak so far) of this process [MB] (Linux: /proc/self/statm)."""
    pages = int(Path("/proc/self/statm").read_text().split()[1])
    now = pages * resource.getpagesize() / 2 ** 20
    return now, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def rank0_breakdown(a, T, size) -> list[str]:
    """Rank 0's set-up on ``size`` ranks, replayed in this process stage by stage
    (the mesh and the model, the node graph, the plan and every other rank's
    share): the arrays each stage holds and the peak RSS after it."""
    # lazy: the runs above start their own processes; only the replay loads the solver here
    from solver.coupling.schemes import scheme_class
    from solver.model import arrays as model_mod, binding, data, layout
    from solver.partitions import partitioning
    from solver.memory import release
    from solver.petscutil import init
    init([])
    rows = [("imports, PETSc", None, rss_mb())]
    store = data.ModelData(keep=False)          # as the command line's: one run
    scene = binding.load(SCENE, sets(a, T, 10), store)
    rows.append(("mesh (let go once the model is built)", footprint(store), rss_mb()))
    treatments = scheme_class(scene.coupling.scheme).treatments(scene)
    mdl = model_mod.build(scene, layout.layer_counts(scene.partitions, treatments), store)
    store.built()
    release()
    n = mdl.n_nodes
    node = mdl.points.nbytes + mdl.mass.nbytes + mdl.fixed.nbytes + mdl.u0.nbytes + mdl.v0.nbytes
    rows.append(("model: per-node arrays (points, mass, fixed, u0, v0)", node, None))
    rows.append(("model: cells and bonds", footprint(mdl) - node, rss_mb()))
    t0 = time.perf_counter()
    graph = mdl.graph()
    rows.append((f"node graph (CSR; built in {time.perf_counter() - t0:.1f} s)", footprint(graph),
                 rss_mb()))
    del graph
    t0 = time.perf_counter()
    whole, graph = partitioning.decide(scene, mdl, size, treatments)
    rows.append((f"layouts, distributions, RCM orders (planned in {time.perf_counter() - t0:.1f} s)",
                 None, rss_mb()))
    numbers = sum(d.number.nbytes for d in whole.dists)
    rows.append(("the whole plan: numbering [n_nodes] per partition", numbers, None))
    rows.append(("the whole plan: layouts and pieces", footprint(whole.dists) - numbers, None))
    items = partitioning.slices(whole, mdl, graph, size, [p.method for p in scene.partitions])
    next(items)                              # rank 0's: its slice and the whole model
    seen = set()                             # what rank 0 holds anyway: not the shares'
    footprint(mdl, seen)
    plan_slice, largest, sent = 0, 0, 0
    for mine, share in items:                # made, pickled and dropped one at a time, as sent
        plan_slice = max(plan_slice, footprint(mine))
        largest = max(largest, footprint(share, set(seen)))
        sent = max(sent, len(pickle.dumps((mine, share), protocol=5,
                                          buffer_callback=lambda b: None)))
        del mine, share
    rows.append((f"largest slice of the plan, ranks 1..{size - 1} (their pieces; the "
                 "numbering of their nodes and neighbours)", plan_slice, None))
    rows.append((f"largest share of ranks 1..{size - 1} (cells and bonds)", largest,
                 None))
    rows.append((f"largest slice and share of ranks 1..{size - 1}, pickled in band (pickle 5 "
                 "as mpi4py.util.pkl5 sends it: the arrays travel from their own memory)", sent,
                 rss_mb()))
    lines = [f"Rank 0's set-up for {size} ranks, replayed stage by stage in one process "
             f"({n:,} nodes): the arrays each stage holds (numpy arrays reachable from its "
             "objects), the resident memory once it is done and the peak so far.", "",
             "| stage / what rank 0 holds | MB | bytes per node | RSS after [MB] | peak RSS "
             "after [MB] |", "|---|---|---|---|---|"]
    for what, nbytes, rss in rows:
        mb = "–" if nbytes is None else f"{nbytes / 2 ** 20:.0f}"
        per = "–" if nbytes is None else f"{nbytes / n:.0f}"
        now, peak = ("–", "–") if rss is None else (f"{x:.0f}" for x in rss)
        lines.append(f"| {what} | {mb} | {per} | {now} | {peak} |")
    return lines


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--a", type=float, default=DEFAULT["a"], help="cube size [m]")
    ap.add_argument("--T", type=float, default=DEFAULT["T"],
                    help="bar thickness [m] (0.032: 2.27 M DOF at a = 0.4 mm)")
    ap.add_argument("--steps", type=int, default=10)
    ap.add_argument("--ranks", default=DEFAULT["ranks"])
    ap.add_argument("--pairs", type=int, default=3,
                    help="runs of 1 then 2 ranks for the set-up ratio (the memory runs are the first)")
    ap.add_argument("--no-breakdown", action="store_true",
                    help="skip replaying rank 0's set-up stage by stage")
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="bench_memory_"))
    counts = sorted(set(map(int, args.ranks.split(","))))
    if counts[0] != 1:
        raise SystemExit(f"--ranks: the ratios are to 1 rank, so 1 must be among them, got {args.ranks!r}")
    runs = []
    for n in counts:
        r = measure(args.a, args.T, args.steps, n, tmp)
        runs.append(r)
        print(f"{n} rank(s): {r['dof']} DOF, set-up {r['setup']:.1f} s, peak RSS per rank "
              f"{', '.join(f'{x:.0f}' for x in r['rss'])} MB", flush=True)
    pairs = []
    if 2 in counts:
        pairs.append((runs[0], next(r for r in runs if r["ranks"] == 2)))
        for k in range(1, args.pairs):
            one, two = (measure(args.a, args.T, args.steps, n, tmp) for n in (1, 2))
            pairs.append((one, two))
            print(f"pair {k + 1}: set-up {one['setup']:.1f} s / {two['setup']:.1f} s = "
                  f"{two['setup'] / one['setup']:.2f}", flush=True)
    lines = lines_for(runs, args.a, args.T, args.steps, pairs)
    if counts[-1] > 1 and not args.no_breakdown:
        lines += [""] + rank0_breakdown(args.a, args.T, counts[-1])
    doc = {"a": args.a, "T": args.T, "ranks": args.ranks} == DEFAULT and not args.no_breakdown
    tables.write("bench_memory", lines, doc=doc)


if __name__ == "__main__":
    main()
