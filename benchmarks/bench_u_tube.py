"""Ma et al. (2018) §4 / Table 1: the U-tube, all-explicit against explicit-implicit runs.

    python benchmarks/bench_u_tube.py [--nc 120] [--end 0.1] [--ratios 3,6,12]
        [--schemes conserving,staggered] [--ranks 2] [-- PETSc options]

Runs configs/u_tube.yaml (half model of shell triangles, nc elements around
the tube; SLOW at nc = 120 and 0.1 s) as separate processes, in one go so the
ratios share the machine's state:

* the all-explicit run (one partition, central difference at 2e-6 s): the
  reference, 100 %;
* every scheme at every ratio m (explicit sector at 2e-6 s, the rest implicit
  at m x 2e-6 s);
* the last of them again on ``--ranks`` ranks (1 vs N).

For each: stepping and total wall time, their ratio to the all-explicit run,
the impact node's vertical displacement against the all-explicit run (max
|u - u_ref| / max |u_ref|), the energy balance at the end ((kinetic + strain
- work) / work) and the number of fine and coarse steps.  Writes
results/bench_u_tube.md and results/u_tube.png (the displacement curves, seed
002 Fig. 7).
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np

import tables                  # noqa: E402  (benchmarks/tables.py, beside this script)

SLOW = True
ROOT = Path(__file__).resolve().parent.parent
SEED = {1: 100.0, 3: 54.7, 6: 41.2, 12: 35.5}
EXPLICIT = ("coupling.scheme=overlap", "partitions=[{name: all, method: fem, group: tube, integrator: explicit, beta: 0.0, "
            "ratio: 1}]")


def run(sets, out, n=1, petsc=()):
    cmd = [sys.executable, "-m", "solver", str(ROOT / "configs/u_tube.yaml"),
           *sum((["--set", s] for s in sets), []), "--set", f"output.file={out}",
           "--set", "output.progress=0", *petsc]
    if n > 1:
        mpiexec = os.environ.get("MTS_MPIEXEC") or "mpiexec"
        cmd = [mpiexec, "-n", str(n), *cmd]
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    if proc.returncode not in (0, 3):
        raise SystemExit(f"bench_u_tube: {' '.join(sets)}: {proc.stderr.strip()}")
    with h5py.File(out) as f:
        e = {k: f[f"energy/{k}"][()] for k in ("kinetic", "strain", "external_work")}
        steps = {k: int(g.attrs["steps"]) for k, g in f["partitions"].items()}
        return {"t": f["probes/impact/t"][()], "u": f["probes/impact/displacement"][()],
                "stepping": float(f.attrs["stepping_wall_time"]),
                "wall": float(f.attrs["wall_time"]), "setup": float(f.attrs["setup_wall_time"]),
                "status": f.attrs["status"], "message": f.attrs["message"],
                "balance": (e["kinetic"][-1] + e["strain"][-1] - e["external_work"][-1]) /
                max(abs(e["external_work"]).max(), 1e-300),
                "steps": steps}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--nc", type=int, default=120, help="elements around the tube")
    ap.add_argument("--end", type=float, default=0.1, help="simulated time [s]")
    ap.add_argument("--ratios", default="3,6,12")
    ap.add_argument("--schemes", default="conserving")
    ap.add_argument("--ranks", type=int, default=2, help="ranks of the 1-vs-N run (1: none)")
    ap.add_argument("petsc", nargs="*", help="PETSc options for every run (after --)")
    args = ap.parse_args(argv)
    tmp = Path(tempfile.mkdtemp())
    base = [f"model.mesh_parameters.nc={args.nc}"]

    def end(m):
        """The last whole system step of m x 2e-6 s at or before --end (a run
        ends on a system step)."""
        return f"time.end={int(args.end / (m * 2e-6) + 1e-9) * m * 2e-6:.12g}"
    ref = run(base + [end(1)] + list(EXPLICIT), tmp / "explicit.h5", petsc=args.petsc)
    scale = np.abs(ref["u"]).max()
    lines = [f"# u_tube (Ma et al. 2018, §4), nc = {args.nc}, {args.end:g} s, explicit step 2e-6 s"
             + (f", PETSc options {' '.join(args.petsc)}" if args.petsc else ""), "",
             "| run | m | ranks | fine / coarse steps | set-up [s] | stepping [s] | stepping / "
             "explicit | total / explicit | Ma et al. (2018) Table 1 | impact-node max error | "
             "energy balance | status |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]

    def row(label, m, n, r):
        err = np.abs(r["u"] - np.interp(r["t"], ref["t"], ref["u"])).max() / scale
        steps = " / ".join(str(v) for v in r["steps"].values())
        lines.append(f"| {label} | {m} | {n} | {steps} | {r['setup']:.1f} | {r['stepping']:.1f} | "
                     f"{100 * r['stepping'] / ref['stepping']:.1f} % | "
                     f"{100 * r['wall'] / ref['wall']:.1f} % | "
                     f"{f'{SEED[m]:.1f} %' if m in SEED else '—'} | "
                     f"{100 * err:.2f} % | {r['balance']:+.2e} | {r['status']}"
                     + (f": {r['message'][:80]}" if r["status"] != "completed" else "") + " |")
        print(lines[-1], flush=True)
    row("all explicit", 1, 1, ref)
    curves = [("all explicit", ref)]
    last = None
    for scheme in args.schemes.split(","):
        for m in [int(x) for x in args.ratios.split(",")]:
            sets = base + [end(m), f"coupling.scheme={scheme}", f"partitions.implicit.ratio={m}"]
            r = run(sets, tmp / f"{scheme}{m}.h5", petsc=args.petsc)
            row(scheme, m, 1, r)
            curves.append((f"{scheme}, m = {m}", r))
            if last is None or last[0] == scheme:      # the first scheme's largest m
                last = (scheme, m, sets, r)
    if args.ranks > 1 and last:
        scheme, m, sets, one = last
        r = run(sets, tmp / "ranks.h5", n=args.ranks, petsc=args.petsc)
        row(scheme, m, args.ranks, r)
        diff = np.abs(r["u"] - one["u"]).max() / scale if r["u"].shape == one["u"].shape \
            else np.nan
        lines += ["", f"{args.ranks} ranks vs 1 ({scheme}, m = {m}): max |u_N - u_1| / max |u| = "
                      f"{diff:.2e}"]
        print(lines[-1])
    tables.write("bench_u_tube", lines)
    plot(curves, Path("results/u_tube.png"), args)


def plot(curves, path, args):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for k, (label, r) in enumerate(curves):
        ax.plot(1e3 * r["t"], 1e3 * r["u"], lw=2.2 if k == 0 else 1.2,
                ls="-" if k == 0 else "--", label=label)
    ax.set(xlabel="t [ms]", ylabel="impact node u_z [mm]",
           title=f"U-tube impact node (Ma et al. 2018, Fig. 7), nc = {args.nc}")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    path.parent.mkdir(exist_ok=True)
    fig.savefig(path, dpi=110)
    print(f"bench_u_tube: wrote {path}")


if __name__ == "__main__":
    main()
