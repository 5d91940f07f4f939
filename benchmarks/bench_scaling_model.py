"""A performance model for N ranks, checked against 2 measured ranks.

    python benchmarks/bench_scaling_model.py [--scenes bar3d,plate_contact,u_tube_graded]
                                             [--counts 2,4,8,16,32,64] [--steps 200]

For three scenes -- the 1.15 M-DOF coupled bar (configs/bar3d.yaml as
bench_scaling.py sizes it), the plate_fracture lattice with contact switched
on, and the graded U-tube with the conserving scheme -- the solver's own rank
assignment and split (``ranks.assign``, ``distribute.split``: what a run on N
ranks would build) give, per rank:

* owned, ghost (another piece's rows a MatMult reads) and external DOF
  (copies refreshed by the exchange), particles and halo particles (another
  piece's particles within the contact search 2r + skin of one of its own);
* bytes and messages received per system step: ghosts at every step of
  their partition, externals (u, v, a) once per system step, halo particles
  (position and velocity) at every step of the dem partition;
* its compute time: each partition's wall per system step measured here on
  1 rank with the other core busy (two 1-rank runs side by side: the ranks
  of a full node share its memory bus and last-level cache), shared over
  the partition's pieces by their owned nonzeros;
* its memory: the 1-rank run's peak RSS less the interpreter's baseline
  (a run of configs/six_dof.yaml), per held DOF, times the rank's held DOF,
  plus the baseline -- what a set-up that holds only its share would need.

Predicted time per system step = max over ranks of (compute + messages x
latency + bytes / bandwidth).  The table uses a stated cluster network
(2 us, 10 GB/s per link); the check against this machine uses MPI's
latency and bandwidth between two ranks here, measured by a ping-pong in
the same run, and compares the predicted 2-rank time with a measured 2-rank
run (target: within 15 %).

Writes docs/benchmarks/bench_scaling_model.md.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_scaling import overrides as bar_overrides  # noqa: E402
from solver.tools.sweep import mpiexec, read_run, run_one  # noqa: E402

LATENCY, BANDWIDTH = 2e-6, 10e9          # the cluster network assumed: 2 us, 10 GB/s per link
TARGET = 0.15                            # predicted 2-rank time within 15 % of the measured one


def scenes(steps: int) -> dict:
    """name -> (scene file, overrides, what it is)."""
    plate_end = steps * 4 * 5.6e-8
    tube_end = steps * 12 * 1e-6
    return {
        "bar3d": (ROOT / "configs" / "bar3d.yaml", bar_overrides(4e-4, steps),
                  "configs/bar3d.yaml at 12 cm x 12 mm x 16 mm, 0.4 mm cubes (overlap, "
                  "explicit fem + verlet dem)"),
        "plate_contact": (ROOT / "configs" / "plate_fracture.yaml",
                          [f"time.end={plate_end}", "model.lattice.contact={stiffness: 3.4e6}",
                           "output.fields=null", "output.energy_every=50"],
                          "configs/plate_fracture.yaml with model.lattice.contact "
                          "(k_n 3.4e6 N/m), before the heating starts (transition scheme)"),
        "u_tube_graded": (ROOT / "configs" / "u_tube_graded.yaml",
                          [f"time.end={tube_end}", "output.energy_every=50"],
                          "configs/u_tube_graded.yaml (shells, conserving: explicit fem + "
                          "implicit fem at m = 12)"),
    }


def pingpong(tmp: Path) -> tuple[float, float]:
    """(latency [s], bandwidth [B/s]) of MPI between two ranks on this machine."""
    script = tmp / "pingpong.py"
    script.write_text(textwrap.dedent("""
        import time, numpy as np
        from mpi4py import MPI
        c = MPI.COMM_WORLD
        def t(nbytes, reps):
            buf = np.zeros(max(nbytes // 8, 1))
            c.Barrier(); t0 = time.perf_counter()
            for _ in range(reps):
                if c.rank == 0:
                    c.Send(buf, 1); c.Recv(buf, 1)
                else:
                    c.Recv(buf, 0); c.Send(buf, 0)
            return (time.perf_counter() - t0) / (2 * reps)
        t(8, 100); small = min(t(8, 2000) for _ in range(3))
        big = min(t(8 << 20, 20) for _ in range(3))
        if c.rank == 0:
            print(small, (8 << 20) / (big - small))
    """))
    out = subprocess.run([mpiexec(), "-n", "2", sys.executable, str(script)],
                         capture_output=True, text=True, check=True).stdout.split()
    return float(out[0]), float(out[1])


def paired(path, sets, tmp: Path, label: str) -> list[dict]:
    """Two 1-rank runs of the scene side by side, one per core (``mpiexec -n 2``,
    each rank alone on COMM_SELF, started together after a barrier): the
    walls a rank measures when every core of the node is busy, sharing the
    memory bus and the last-level cache, as the ranks of an N-rank run do."""
    script = tmp / "paired.py"
    script.write_text(textwrap.dedent("""
        import sys
        from mpi4py import MPI
        import solver
        path, stem, *sets = sys.argv[1:]
        world = MPI.COMM_WORLD
        scene = solver.load(path, [*sets, f"output.file={stem}_{world.rank}.h5",
                                   "output.progress=0"])
        world.Barrier()
        solver.run(scene, comm=MPI.COMM_SELF, overwrite=True)
    """))
    stem = tmp / f"{label}_paired"
    proc = subprocess.run([mpiexec(), "-n", "2", sys.executable, str(script), str(path),
                           str(stem), *sets], capture_output=True, text=True,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})
    if proc.returncode != 0:
        raise SystemExit(f"bench_scaling_model: the paired runs of {label} failed: "
                         f"{proc.stderr.strip()[-2000:]}")
    return [read_run(f"{stem}_{r}.h5") for r in (0, 1)]


def baseline_rss(tmp: Path) -> float:
    """Peak RSS [MB] of a run of the smallest scene: the interpreter, numpy, PETSc."""
    out = tmp / "baseline.h5"
    run_one(str(ROOT / "configs" / "six_dof.yaml"), 1, [], out)
    return float(attrs(out)["peak_rss_mb_per_rank"][0])


def attrs(path) -> dict:
    import h5py  # lazy: only the runs' files need it
    with h5py.File(path) as f:
        return dict(f.attrs)


class Geometry:
    """One scene's model, layouts and per-partition costs (no run)."""

    def __init__(self, path, sets):
        from solver.coupling.schemes import scheme_class
        from solver.model import arrays as model_mod, binding
        from solver.model import layout as overlap
        from solver.partitions.partitioning import owned_nonzeros
        self.scene = scene = binding.load(str(path), sets)
        treat = scheme_class(scene.coupling.scheme).treatments(scene)
        layers = overlap.layer_counts(scene.partitions, treat)
        self.mdl = mdl = model_mod.build(scene, layers)
        self.graph = mdl.graph()
        self.layouts = overlap.derive(self.graph, scene.partitions, layers)
        self.counts = mdl.dofmap.counts
        self.nnz = lambda nodes: owned_nonzeros(self.graph, nodes, mdl.dofmap)  # noqa: E731
        R = scene.system_ratio
        self.steps = [R // p.ratio for p in scene.partitions]
        self.n_dof = int(self.counts.sum())
        contact = mdl.contact
        self.reach = None if contact is None else 2 * contact.radius + contact.skin
        self.dim = mdl.points.shape[1] if mdl.points is not None else 1

    def is_dem(self, p) -> bool:
        return self.scene.partitions[p].method == "dem"

    def halo(self, nodes, piece_of) -> np.ndarray:
        """Halo particles of every piece of a dem partition (contact): another
        piece's particles within 2r + skin of one of the piece's own."""
        from scipy.spatial import cKDTree
        pairs = cKDTree(self.mdl.points[nodes]).query_pairs(self.reach, output_type="ndarray")
        a, b = nodes[pairs[:, 0]], nodes[pairs[:, 1]]
        cross = piece_of[a] != piece_of[b]
        pieces = np.concatenate([piece_of[a][cross], piece_of[b][cross]])
        other = np.concatenate([b[cross], a[cross]])
        key = np.unique(pieces.astype(np.int64) * (self.mdl.n_nodes + 1) + other)
        return np.bincount(key // (self.mdl.n_nodes + 1), minlength=piece_of.max() + 1)

    def ranks_at(self, N: int, walls) -> list[dict]:
        """Per rank: owned/ghost/external/held DOF, particles, halo particles,
        bytes and messages per system step, and (partition, nonzero share) pairs;
        ranks assigned by the partitions' measured 1-rank ``walls`` per system
        step, as ``balance: measured`` assigns them."""
        from solver.partitions import distribute, ranks
        costs = [ranks.measured_cost(w, 1) for w in walls]
        asg = ranks.assign(N, costs, [lay.n_owned for lay in self.layouts],
                           [None] * len(self.layouts), basis="measured",
                           ride=self.scene.scheme.rides)
        out = [{"owned": 0, "ghost": 0, "ext": 0, "held": 0, "particles": 0, "halo": 0,
                "bytes": 0.0, "msgs": 0, "work": []} for _ in range(N)]
        for p, lay in enumerate(self.layouts):
            dist = distribute.split(lay, self.graph, len(asg.ranks[p]))
            piece_of = np.full(self.mdl.n_nodes, -1)
            for piece in dist.pieces:
                piece_of[piece.owned] = piece.piece
            halo = (self.halo(lay.owned, piece_of) if self.is_dem(p) and self.reach
                    and len(dist.pieces) > 1 else np.zeros(len(dist.pieces), int))
            total = self.nnz(lay.owned) or 1
            for piece, r in zip(dist.pieces, asg.ranks[p]):
                cols = np.unique(self.graph.rows(piece.held))
                cols = cols[(piece_of[cols] >= 0) & (piece_of[cols] != piece.piece)]
                ghost = int(self.counts[cols].sum())
                ext = int(self.counts[piece.external].sum())
                peers = np.unique(piece_of[cols]).size
                ext_peers = np.unique(piece.external_owner).size if piece.external.size else 0
                d = out[r]
                d["owned"] += int(self.counts[piece.owned].sum())
                d["ghost"] += ghost
                d["ext"] += ext
                d["held"] += int(self.counts[piece.held].sum()) + ghost
                n_halo = int(halo[piece.piece]) if piece.piece < halo.size else 0
                if self.is_dem(p):
                    d["particles"] += piece.n_owned
                    d["halo"] += n_halo
                steps = self.steps[p]
                d["bytes"] += 8.0 * (ghost * steps + 3 * ext + 2 * self.dim * n_halo * steps)
                d["msgs"] += (peers + (peers if n_halo else 0)) * steps + ext_peers
                d["work"].append((p, self.nnz(piece.owned) / total))
        return out


def predict(rows, walls, rest, latency, bandwidth) -> float:
    """Time per system step: the slowest rank's compute and messages; ``rest``:
    the 1-rank system step's time outside the partitions (exchange copies,
    interface solve, energy, output), shared evenly over the ranks."""
    return max(sum(walls[p] * share for p, share in d["work"]) + rest / len(rows)
               + d["msgs"] * latency + d["bytes"] / bandwidth for d in rows)


def measure(path, sets, n, tmp, label) -> dict:
    out = tmp / f"{label}_{n}.h5"
    r = run_one(str(path), n, sets, out)
    a = attrs(out)
    r["rss"] = np.asarray(a["peak_rss_mb_per_rank"], dtype=float)
    r["setup"] = float(a["setup_wall_time"])
    return r


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--scenes", default="bar3d,plate_contact,u_tube_graded")
    ap.add_argument("--counts", default="2,4,8,16,32,64")
    ap.add_argument("--steps", type=int, default=200, help="system steps of the measured runs")
    ap.add_argument("--out", default=str(ROOT / "docs" / "benchmarks" / "bench_scaling_model.md"))
    args = ap.parse_args()
    counts = [int(x) for x in args.counts.split(",")]
    chosen = [s.strip() for s in args.scenes.split(",")]
    table = scenes(args.steps)
    tmp = Path(tempfile.mkdtemp(prefix="bench_scaling_model_"))
    lat_here, bw_here = pingpong(tmp)
    base = baseline_rss(tmp)
    print(f"MPI here: {lat_here * 1e6:.2f} us, {bw_here / 1e9:.2f} GB/s; baseline RSS {base:.0f} MB",
          flush=True)
    lines = ["# A performance model for N ranks, checked on 2", "",
             "`python benchmarks/bench_scaling_model.py` (run by `./run.sh bench`). The solver's "
             "own rank assignment (by measured cost, as `balance: measured` makes it) and split "
             "for N ranks (no run), each partition's wall per system "
             f"step measured on 1 rank ({args.steps} system steps) beside a second 1-rank run "
             "of the same scene on the other core (every core busy, as on a full node: they "
             "share the memory bus and the last-level cache), and a network: compute of a "
             "rank = the sum over its pieces of their partition's 1-rank wall times the piece's "
             "share of the owned nonzeros, plus the 1-rank step's rest (exchange, interface solve, "
             "energy, output) shared evenly; predicted time per system step = max over ranks of "
             "(compute + messages x latency + bytes / bandwidth). Bytes per system step: ghosts "
             "at every step of their partition, externals (u, v, a) once, halo particles "
             "(position and velocity) at every dem step. Memory per rank: the 1-rank run's "
             f"peak RSS less a baseline of {base:.0f} MB (configs/six_dof.yaml: interpreter, "
             "numpy, PETSc), per held DOF, times the rank's held DOF, plus the baseline. "
             f"Cluster network assumed: {LATENCY * 1e6:.0f} us, {BANDWIDTH / 1e9:.0f} GB/s per "
             f"link. This machine's MPI, measured by a ping-pong in this run: "
             f"{lat_here * 1e6:.2f} us, {bw_here / 1e9:.2f} GB/s. All figures from one run on "
             "this shared 2-core machine.", ""]
    checks = []
    for name in chosen:
        path, sets, about = table[name]
        geo = Geometry(path, sets)
        one = measure(path, sets, 1, tmp, name)
        n_sys = one["system_steps"]
        t1 = one["stepping_s"] / n_sys
        alone = [one[f"{p.name}_s"] / n_sys for p in geo.scene.partitions]
        # the model's compute: each partition's 1-rank wall with the other core busy
        pair = paired(path, sets, tmp, name)
        walls = [float(np.mean([r[f"{p.name}_s"] / r["system_steps"] for r in pair]))
                 for p in geo.scene.partitions]
        t1_busy = float(np.mean([r["stepping_s"] / r["system_steps"] for r in pair]))
        rest = max(t1_busy - sum(walls), 0.0)
        per_dof = (one["rss"][0] - base) / max(geo.n_dof, 1)
        two = measure(path, sets, 2, tmp, name)
        rows2 = geo.ranks_at(2, walls)
        pred2 = predict(rows2, walls, rest, lat_here, bw_here)
        meas2 = two["stepping_s"] / two["system_steps"]
        ok = abs(pred2 / meas2 - 1) <= TARGET
        checks.append((name, t1, pred2, meas2, ok, one, two))
        lines += [f"## {name}: {geo.n_dof:,} DOF", "", about + ".", "",
                  f"1 rank: {1e3 * t1:.2f} ms per system step alone (partitions "
                  + ", ".join(f"{p.name} {1e3 * w:.2f} ms" for p, w in zip(geo.scene.partitions, alone))
                  + f"), {1e3 * t1_busy:.2f} ms beside another (partitions "
                  + ", ".join(f"{p.name} {1e3 * w:.2f} ms" for p, w in zip(geo.scene.partitions, walls))
                  + f", the rest {1e3 * rest:.2f} ms: the model's compute), peak RSS {one['rss'][0]:.0f} MB ({per_dof * 1e6:.0f} B per DOF above the baseline).",
                  "", "| N | owned DOF per rank (min / max) | ghost DOF (max) | external DOF (max) | "
                  "particles (max) | halo particles (max) | bytes received per system step (max) | "
                  "messages (max) | load imbalance (max / mean compute) | memory per rank (max) [MB] "
                  "| predicted ms per system step | predicted speed-up |",
                  "|---|---|---|---|---|---|---|---|---|---|---|---|"]
        for N in counts:
            rows = rows2 if N == 2 else geo.ranks_at(N, walls)
            work = np.array([sum(walls[p] * s for p, s in d["work"]) for d in rows])
            t = predict(rows, walls, rest, LATENCY, BANDWIDTH)
            mem = base + per_dof * max(d["held"] for d in rows)
            lines.append(
                f"| {N} | {min(d['owned'] for d in rows):,} / {max(d['owned'] for d in rows):,} | "
                f"{max(d['ghost'] for d in rows):,} | {max(d['ext'] for d in rows):,} | "
                f"{max(d['particles'] for d in rows):,} | {max(d['halo'] for d in rows):,} | "
                f"{max(d['bytes'] for d in rows) / 1e3:.1f} kB | {max(d['msgs'] for d in rows)} | "
                f"{work.max() / work.mean():.2f} | {mem:.0f} | {1e3 * t:.3f} | {t1 / t:.1f} |")
        lines.append("")
        print("\n".join(lines[-len(counts) - 8:]), flush=True)
    lines += ["## The model against 2 measured ranks", "",
              f"Predicted with this machine's MPI figures; target: within {100 * TARGET:.0f} %.", "",
              "| scene | 1 rank [ms per system step] | 2 ranks predicted | 2 ranks measured | "
              "predicted / measured | measured speed-up | set-up 1 / 2 ranks [s] | peak RSS "
              "1 rank / 2 ranks [MB] | within target |", "|---|---|---|---|---|---|---|---|---|"]
    for name, t1, pred2, meas2, ok, one, two in checks:
        lines.append(f"| {name} | {1e3 * t1:.2f} | {1e3 * pred2:.2f} | {1e3 * meas2:.2f} | "
                     f"{pred2 / meas2:.2f} | {t1 / meas2:.2f} | {one['setup']:.1f} / "
                     f"{two['setup']:.1f} | {one['rss'][0]:.0f} / "
                     f"{' + '.join(f'{x:.0f}' for x in two['rss'])} | {'yes' if ok else 'no'} |")
    text = "\n".join(lines) + "\n"
    print(text)
    Path(args.out).write_text(text)


if __name__ == "__main__":
    main()
