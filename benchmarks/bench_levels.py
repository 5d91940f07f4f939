"""Automatic multi-time-stepping against one uniform step (docs/guide/levels.md).

    python benchmarks/bench_levels.py [--scene u_tube_graded] [--end 0.02 (U-tube default)]
        [--hand 3,6,12] [--scaling 1.5] [--set key=value ...]

Runs the scene as separate processes, in one go so the runs share the
machine's state, all from the same mesh:

* uniform explicit: one partition, its own largest stable uniform step
  (``time.dt: auto`` with ``time.levels.max_ratio: 1``: 0.9 x the whole
  model's critical step) -- the reference, 100 %;
* automatic levels: ``partitions: auto``, ``time.dt: auto``;
* uniform explicit and automatic levels with mass scaling to ``--scaling``
  x the smallest element bound (``time.mass_scaling.dt``);
* the scene's own hand-written partitions at each ``--hand`` ratio (the
  U-tube's explicit sector + implicit rest, conserving scheme), where the
  scene has an ``implicit`` partition.

For each: set-up, stepping and total wall (the process, set-up included),
their ratio to the uniform run, the first probe's max error against the
uniform run (max |u - u_ref| / max |u_ref|, the reference interpolated to
the run's times), the predicted speed-up the level table printed and the
measured stepping speed-up against it.  Writes results/bench_levels_<scene>.md
(and the docs page's generated block for the default U-tube run) and
results/bench_levels_<scene>.png (the probe's displacement).
"""
from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

import tables                  # noqa: E402  (benchmarks/tables.py, beside this script)

SLOW = True
ROOT = Path(__file__).resolve().parent.parent
UNIFORM = ["partitions=auto", "time.dt=auto", "time.levels.max_ratio=1", "coupling.scheme=overlap"]
AUTO = ["partitions=auto", "time.dt=auto", "coupling.scheme=overlap"]


def run(scene, sets, out, n=1):
    cmd = [sys.executable, "-m", "solver", str(scene), *sum((["--set", s] for s in sets), []),
           "--set", f"output.file={out}", "--set", "output.progress=0", "--overwrite"]
    if n > 1:
        cmd = [os.environ.get("MTS_MPIEXEC") or "mpiexec", "-n", str(n), *cmd]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"run failed ({' '.join(sets)}): {proc.stderr.strip()[-500:]}")
    predicted = re.search(r"predicted speed-up ([0-9.e+]+) x", proc.stdout)
    added = re.search(r"kg added \(([0-9.e+-]+) %", proc.stdout)
    with h5py.File(out, "r") as f:
        a = f.attrs
        g = f["probes"][sorted(f["probes"])[0]]
        parts = f["partitions"]
        return {"t": g["t"][()], "u": g["displacement"][()],
                "stepping": float(a["stepping_wall_time"]), "wall": wall,
                "setup": wall - float(a["stepping_wall_time"]),
                "steps": {k: int(p.attrs["steps"]) for k, p in parts.items()},
                "levels": {k: p.attrs.get("level_ratios") for k, p in parts.items()},
                "dt": {k: float(p.attrs.get("fine_dt", p.attrs["dt"])) for k, p in parts.items()},
                "predicted": float(predicted.group(1)) if predicted else None,
                "added": float(added.group(1)) if added else 0.0, "status": a["status"]}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="u_tube_graded")
    ap.add_argument("--end", type=float, help="simulated time [s] (default: the scene's)")
    ap.add_argument("--hand", default="3,6,12", help="hand-written ratios (scenes with an "
                    "implicit partition)")
    ap.add_argument("--scaling", type=float, default=1.5,
                    help="mass-scaling target as a multiple of the smallest element bound")
    ap.add_argument("--set", action="append", default=[], dest="sets")
    args = ap.parse_args(argv)
    if args.end is None and args.scene == "u_tube_graded":
        args.end = 0.02                  # the impact and one rebound: about 9 minutes in all
    scene = ROOT / "configs" / f"{args.scene}.yaml"
    tmp = Path(tempfile.mkdtemp())
    base = list(args.sets) + ([f"time.end={args.end!r}"] if args.end else [])
    ref = run(scene, base + UNIFORM, tmp / "uniform.h5")
    scale = np.abs(ref["u"]).max()
    h_u = next(iter(ref["dt"].values()))
    lines = [f"# {args.scene}: automatic levels against one uniform step of {h_u:.4g} s"
             + (f" ({' '.join(args.sets)})" if args.sets else ""), "",
             "| run | levels | fine step [s] | added mass | set-up [s] | stepping [s] | "
             "stepping / uniform | total / uniform | predicted speed-up | measured / predicted | "
             "probe max error |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    curves = [("uniform explicit", ref)]

    def row(label, r):
        err = np.abs(r["u"] - np.interp(r["t"], ref["t"], ref["u"])).max() / scale
        lv = [v for v in r["levels"].values() if v is not None]
        lv = ", ".join(map(str, lv[0])) if lv else ("1" if len(r["levels"]) == 1 else "—")
        speed = ref["stepping"] / r["stepping"]
        pred = r["predicted"]
        lines.append(f"| {label} | {lv} | {min(r['dt'].values()):.4g} | {r['added']:.3g} % | "
                     f"{r['setup']:.1f} | {r['stepping']:.1f} | "
                     f"{100 * r['stepping'] / ref['stepping']:.1f} % | "
                     f"{100 * r['wall'] / ref['wall']:.1f} % | "
                     f"{f'{pred:.3g}' if pred else '—'} | "
                     f"{f'{speed / pred:.2f}' if pred else '—'} | {100 * err:.3f} % |")
        print(lines[-1], flush=True)
    row("uniform explicit", ref)
    r = run(scene, base + AUTO, tmp / "auto.h5")
    row("automatic levels", r)
    curves.append(("automatic levels", r))
    if args.scaling:
        from solver.model import binding, element_bounds, arrays  # lazy: after the runs' start
        from solver.petscutil import init
        init([])
        sc = binding.load(scene, base + AUTO)
        mdl = arrays.build(sc)
        smallest = min(float(b.steps.min()) for b in element_bounds.model_bounds(sc, mdl))
        target = args.scaling * smallest
        ms = [f"time.mass_scaling.dt={target!r}", "time.mass_scaling.max_added=1.0"]
        r = run(scene, base + UNIFORM + ms, tmp / "uniform_ms.h5")
        row(f"uniform + mass scaling to {args.scaling:g} x bound", r)
        r = run(scene, base + AUTO + ms, tmp / "auto_ms.h5")
        row(f"levels + mass scaling to {args.scaling:g} x bound", r)
        curves.append((f"levels + mass scaling {args.scaling:g}x", r))
    if args.hand and "implicit" in scene.read_text():
        from solver.scene import load as load_scene  # lazy: after the runs' start
        written = load_scene(scene, list(args.sets))
        dt, end = written.time.dt, args.end or written.time.end
        for m in [int(x) for x in args.hand.split(",")]:
            whole = f"time.end={int(end / (m * dt) + 1e-9) * m * dt!r}"    # whole system steps
            r = run(scene, base + [whole, f"partitions.implicit.ratio={m}"], tmp / f"hand{m}.h5")
            row(f"hand-written, m = {m}", r)
    tables.write(f"bench_levels_{args.scene}", lines)
    plot(curves, Path(f"results/bench_levels_{args.scene}.png"), args.scene)


def plot(curves, path, name):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4))
    for label, r in curves:
        ax.plot(1e3 * r["t"], r["u"], label=label, lw=1)
    ax.set_xlabel("t [ms]")
    ax.set_ylabel("probe displacement [m]")
    ax.set_title(f"{name}: automatic levels against one uniform step")
    ax.legend()
    fig.tight_layout()
    path.parent.mkdir(exist_ok=True)
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
