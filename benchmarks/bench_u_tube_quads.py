"""The graded U-tube (configs/u_tube_graded.yaml) with MITC4 quadrilaterals
against the triangle run: all explicit, the same load, the impact node's
vertical displacement and the cost.

    python benchmarks/bench_u_tube_quads.py [--end 0.02]

Three runs, one partition (central difference), as separate processes in one
go: the triangles (26,060 DKT/Allman cells) at 1e-6 s; the same mesh
recombined into quadrilaterals (meshes/u_tube_graded.geo with quads = 1:
12,795 MITC4 cells on 12,880 nodes) at 1e-6 s; and the quadrilaterals at
1.8e-6 s, below their own critical step.  For each: the critical step, the
stepping wall time and its ratio to the triangles', the impact node's
displacement against the triangle run (max |u - u_tri| / max |u_tri|) and the
energy balance at the end.  Writes docs/benchmarks/bench_u_tube_quads.md and
docs/figures/bench_u_tube_quads.png.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np

import tables                  # noqa: E402  (benchmarks/tables.py, beside this script)

ROOT = Path(__file__).resolve().parent.parent
EXPLICIT = ("coupling.scheme=overlap", "partitions=[{name: all, method: fem, group: tube, "
            "integrator: explicit, beta: 0.0, ratio: 1}]")
RUNS = (("triangles", 0, 1e-6), ("quadrilaterals", 1, 1e-6), ("quadrilaterals", 1, 1.8e-6))


def run(quads, dt, end, out):
    cmd = [sys.executable, "-m", "solver", str(ROOT / "configs/u_tube_graded.yaml"),
           *sum((["--set", s] for s in (*EXPLICIT, f"model.mesh_parameters.quads={quads}",
                                        f"time.dt={dt}", f"time.end={end}",
                                        f"output.file={out}", "output.progress=0",
                                        "output.energy_every=10")), [])]
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    if proc.returncode != 0:
        raise SystemExit(f"bench_u_tube_quads: quads={quads} dt={dt}: {proc.stderr.strip()}")
    with h5py.File(out) as f:
        e = {k: f[f"energy/{k}"][()] for k in ("kinetic", "strain", "external_work")}
        return {"t": f["probes/impact/t"][()], "u": f["probes/impact/displacement"][()],
                "stepping": float(f.attrs["stepping_wall_time"]),
                "critical": float(f["partitions/all"].attrs["critical_step"]),
                "balance": (e["kinetic"][-1] + e["strain"][-1] - e["external_work"][-1]) /
                max(abs(e["external_work"]).max(), 1e-300)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--end", type=float, default=0.02, help="simulated time [s]")
    args = ap.parse_args()
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        for k, (label, quads, dt) in enumerate(RUNS):
            end = round(args.end / dt) * dt
            results.append(run(quads, dt, end, Path(tmp) / f"r{k}.h5"))
    ref = results[0]
    lines = [f"All explicit to {args.end:g} s (the 10 ms half-sine impact and its aftermath), one "
             "rank; the displacement difference against the triangle run, interpolated to its "
             "samples.", "",
             "| cells | dt | critical step | stepping [s] | stepping / triangles' | impact node vs "
             "triangles | energy balance |", "|---|---|---|---|---|---|---|"]
    for (label, quads, dt), r in zip(RUNS, results):
        u = np.interp(ref["t"], r["t"], r["u"])
        diff = np.abs(u - ref["u"]).max() / np.abs(ref["u"]).max()
        lines.append(f"| {label} | {dt:.2g} s | {r['critical']:.3g} s | {r['stepping']:.1f} | "
                     f"{r['stepping'] / ref['stepping']:.2f} | "
                     f"{'—' if r is ref else f'{100 * diff:.2f} %'} | {r['balance']:+.1e} |")
    tables.write("bench_u_tube_quads", lines)
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4))
    for (label, quads, dt), r, style in zip(RUNS, results, ("-", "--", ":")):
        ax.plot(1e3 * r["t"], 1e3 * r["u"], style, label=f"{label}, dt {dt:.2g} s")
    ax.set_xlabel("t [ms]")
    ax.set_ylabel("impact node u_z [mm]")
    ax.legend()
    ax.set_title("Graded U-tube, all explicit: triangles vs MITC4 quadrilaterals")
    fig.tight_layout()
    fig.savefig(ROOT / "docs" / "figures" / "bench_u_tube_quads.png", dpi=110)
    print("figure: docs/figures/bench_u_tube_quads.png")


if __name__ == "__main__":
    main()
