"""Metamaterial (Li et al. 2023, §4): run time against eta, as ratios in one run.

    ./run.sh bench            (or: python benchmarks/bench_metamaterial.py [--scene ...] [--ratios ...])

Serial (in this process, reference off so only the coupled run is timed):
  - wall time of the eta = 1 run (75,000 base steps; target <= 1.5 s),
  - per-step costs c_F, c_D of the two partitions measured at eta = 1,
  - for every eta the measured speed-up t_1 / t_eta against the cost model
    (c_F + c_D) / (c_F / eta + c_D) (target: >= 95 % of it at eta = 20),
    next to Li et al. (2023) Table 1 (171, 150, 140, 134, 130, 125, 112 s).
Two ranks (mpiexec -n 2, one partition per rank): stepping time per eta and the
time each rank waits in the exchange per system step (load imbalance).
Writes results/bench_<scene>.md and the generated block of docs/benchmarks/bench_<scene>.md,
and prints it.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py

from solver import scene as scene_mod

from solver.model import binding
from solver.petscutil import init
from solver.tools.sweep import mpiexec

ROOT = Path(__file__).resolve().parents[1]
SEED_000_TABLE_1 = {1: 171, 2: 150, 3: 140, 4: 134, 5: 130, 10: 125, 20: 112}


def serial(scene_path, eta, out):
    from mpi4py import MPI

    from solver.driver.runner import run
    scene = binding.load(scene_path, [f"partitions.fem.ratio={eta}", "reference=none",
                                        f"output.file={out}", "output.progress=0"])
    res = run(scene, MPI.COMM_SELF, log=lambda *a: None)
    return res.attrs, res.partitions


def parallel(scene_path, eta, out):
    cmd = [mpiexec(), "-n", "2", sys.executable, "-m", "solver", str(scene_path),
           "--set", f"partitions.fem.ratio={eta}", "--set", "reference=none",
           "--set", f"output.file={out}", "--set", "output.progress=0"]
    proc = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ})
    if proc.returncode:
        raise SystemExit(f"2-rank run failed: {proc.stderr.strip().splitlines()[-1:]}")
    with h5py.File(out) as f:
        return dict(f.attrs), {k: dict(g.attrs) for k, g in f["partitions"].items()}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="configs/metamaterial.yaml")
    ap.add_argument("--ratios", default="1,2,3,4,5,10,20")
    ap.add_argument("--no-parallel", action="store_true")
    args = ap.parse_args(argv)
    init([])
    ratios = [int(x) for x in args.ratios.split(",")]
    name = Path(args.scene).stem
    tmp = Path(tempfile.mkdtemp())
    rows = {}
    for eta in ratios:
        attrs, parts = serial(ROOT / args.scene, eta, tmp / f"s{eta}.h5")
        rows[eta] = {"serial": attrs["stepping_wall_time"], "wall": attrs["wall_time"],
                     "steps": attrs["n_system_steps"], "parts": parts}
    p1 = rows[ratios[0]]["parts"]
    c_f = p1["fem"]["wall_time"] / p1["fem"]["steps"]
    c_d = p1["dem"]["wall_time"] / p1["dem"]["steps"]
    t1 = rows[ratios[0]]["serial"]
    lines = [f"# {name}: run time against η (this machine, one run)", "",
             f"η = 1 on 1 rank: {rows[ratios[0]]['steps']} system steps, wall {rows[ratios[0]]['wall']:.3f} s "
             f"(stepping {t1:.3f} s; target <= 1.5 s)",
             f"per-step costs at η = 1: c_F = {1e6 * c_f:.2f} us (fem), c_D = {1e6 * c_d:.2f} us (dem); "
             f"the rest of a system step (exchange, probes, loop) = "
             f"{1e6 * (t1 / rows[ratios[0]]['steps'] - c_f - c_d):.2f} us", "",
             "| η | serial stepping [s] | time ratio | speed-up | cost-model speed-up | measured / model "
             "| Li et al. (2023) Table 1 speed-up | 2 ranks stepping [s] | 2-rank speed-up | wait fem rank [us/step] "
             "| wait dem rank [us/step] |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for eta in ratios:
        r = rows[eta]
        model = (c_f + c_d) / (c_f / eta + c_d)
        speed = t1 / r["serial"]
        seed = SEED_000_TABLE_1[1] / SEED_000_TABLE_1[eta] if eta in SEED_000_TABLE_1 else float("nan")
        par = "| - | - | - | -"
        if not args.no_parallel:
            attrs, parts = parallel(ROOT / args.scene, eta, tmp / f"p{eta}.h5")
            r["parallel"] = attrs["stepping_wall_time"]
            n = attrs["n_system_steps"]
            wait = {k: 1e6 * parts[k]["exchange_wall_time"] / n for k in ("fem", "dem")}
            base = rows[ratios[0]].get("parallel", r["parallel"])
            par = (f"| {r['parallel']:.3f} | {base / r['parallel']:.2f} | {wait['fem']:.2f} "
                   f"| {wait['dem']:.2f}")
        lines.append(f"| {eta} | {r['serial']:.3f} | {r['serial'] / t1:.3f} | {speed:.2f} | {model:.2f} "
                     f"| {speed / model:.2f} | {seed:.2f} {par} |")
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import tables
    tables.write(f"bench_{name}", lines,
                 doc=args.ratios == "1,2,3,4,5,10,20" and not args.no_parallel)


if __name__ == "__main__":
    main()
