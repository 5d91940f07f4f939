"""Error against run time: run a scene for several step ratios and report.

    python -m solver.sweep SCENE.yaml --ratios 1,2,5,10,20 [-n 1,2]
        [--treatments taylor,literal] [--partition NAME] [--out DIR] [--set k=v ...]

For every rank count, external-data treatment and ratio eta, the coarse
partition (default: the one with the largest ratio in the scene) steps
eta*time.dt while the others keep theirs.  Each run is a separate process
(launched through the matching mpiexec for n > 1); its stepping wall time and
probe errors are read back from its HDF5 file.  Writes DIR/sweep.csv,
DIR/sweep.md and DIR/sweep.png and prints the Markdown table.
"""
from __future__ import annotations

import argparse
import csv
import os
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np

from .errors import SceneError
from .scene import load


def mpiexec() -> str:
    return os.environ.get("MTS_MPIEXEC") or shutil.which("mpiexec.mpich") or shutil.which("mpiexec")


def run_one(scene_path, n, sets, out_file):
    cmd = [sys.executable, "-m", "solver", scene_path, *sum((["--set", s] for s in sets), []),
           "--set", f"output.file={out_file}", "--set", "output.progress=0"]
    if n > 1:
        cmd = [mpiexec(), "-n", str(n), *cmd]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        tail = (proc.stderr.strip().splitlines() or ["(no message)"])[-1]
        raise SystemExit(f"sweep: run failed ({' '.join(cmd[-8:])}): {tail}")
    return read_run(out_file)


def read_run(path) -> dict:
    with h5py.File(path, "r") as f:
        a = f.attrs
        row = {"stepping_s": float(a["stepping_wall_time"]), "wall_s": float(a["wall_time"]),
               "exchange_s": float(a["exchange_wall_time"]), "system_steps": int(a["n_system_steps"])}
        for name, g in f["partitions"].items():
            row[f"{name}_s"] = float(g.attrs["wall_time"])
            row[f"{name}_steps"] = int(g.attrs["steps"])
        errs = [(g.attrs.get("max_rel_error", np.nan), g.attrs.get("rms_rel_error", np.nan))
                for g in f["probes"].values()]
        probe = next(iter(f["probes"])) if len(f["probes"]) else ""
    row["probe"] = probe
    row["max_rel_error"] = float(errs[0][0]) if errs else float("nan")
    row["rms_rel_error"] = float(errs[0][1]) if errs else float("nan")
    return row


def markdown(rows) -> str:
    head = ("| ranks | treatment | η | system steps | stepping wall [s] | time ratio | speed-up | "
            "max rel. error | RMS rel. error |")
    lines = [head, "|---" * (head.count("|") - 1) + "|"]
    for r in rows:
        lines.append(f"| {r['ranks']} | {r['treatment']} | {r['eta']} | {r['system_steps']} | "
                     f"{r['stepping_s']:.3f} | {r['time_ratio']:.3f} | {r['speedup']:.2f} | "
                     f"{r['max_rel_error']:.2e} | {r['rms_rel_error']:.2e} |")
    return "\n".join(lines)


def plot(rows, path, title):
    """Three panels: error vs eta, error vs wall time, wall time vs eta.
    Colour = treatment, line style = rank count (solid 1, dashed 2, ...)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax0, ax1, ax2) = plt.subplots(1, 3, figsize=(15, 4.4))
    treatments = list(dict.fromkeys(r["treatment"] for r in rows))
    ranks = list(dict.fromkeys(r["ranks"] for r in rows))
    styles = ["-", "--", ":", "-."]
    for ti, treat in enumerate(treatments):
        for ri, n in enumerate(ranks):
            sel = [r for r in rows if r["ranks"] == n and r["treatment"] == treat]
            kw = dict(color=f"C{ti}", ls=styles[ri % 4], marker="o", ms=4,
                      label=f"{treat}, {n} rank{'s' if n > 1 else ''}")
            eta = [r["eta"] for r in sel]
            err = [r["max_rel_error"] for r in sel]
            wall = [r["stepping_s"] for r in sel]
            ax0.loglog(eta, err, **kw)
            ax1.loglog(wall, err, **kw)
            ax2.semilogx(eta, wall, **kw)
            if ti == 0 and ri == 0:
                for r in sel:
                    ax1.annotate(f"η={r['eta']}", (r["stepping_s"], r["max_rel_error"]),
                                 fontsize=7, xytext=(4, -9), textcoords="offset points")
    ax0.set(xlabel="step ratio η", ylabel="max relative error of the probe", title="error per η")
    ax1.set(xlabel="stepping wall time [s]", ylabel="max relative error of the probe",
            title="error against run time")
    ax2.set(xlabel="step ratio η", ylabel="stepping wall time [s]", title="run time per η")
    for ax in (ax0, ax1, ax2):
        ax.grid(True, which="both", alpha=0.3)
    ax2.legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m solver.sweep", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("--ratios", default="1,2,3,4,5,10,20")
    ap.add_argument("-n", "--ranks", default="1", help="rank counts, e.g. 1,2")
    ap.add_argument("--treatments", default="taylor,literal")
    ap.add_argument("--partition", help="partition whose ratio is swept (default: largest ratio)")
    ap.add_argument("--out", help="output directory (default results/sweep_<scene>)")
    ap.add_argument("--set", action="append", default=[], dest="sets")
    args = ap.parse_args(argv)
    try:
        scene = load(args.scene, args.sets)
        ratios = [int(x) for x in args.ratios.split(",")]
        ranks = [int(x) for x in args.ranks.split(",")]
    except (SceneError, ValueError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    coarse = args.partition or max(scene.partitions, key=lambda p: p.ratio).name
    if coarse not in {p.name for p in scene.partitions}:
        print(f"error: --partition: no partition named {coarse!r}", file=sys.stderr)
        return 2
    out = Path(args.out or f"results/sweep_{scene.name}")
    (out / "runs").mkdir(parents=True, exist_ok=True)
    rows = []
    for n in ranks:
        for treat in args.treatments.split(","):
            base = None
            for eta in ratios:
                f = out / "runs" / f"n{n}_{treat}_eta{eta}.h5"
                row = run_one(args.scene, n, [*args.sets, f"partitions.{coarse}.ratio={eta}",
                                              f"coupling.external={treat}"], f)
                row.update(ranks=n, treatment=treat, eta=eta)
                base = base or row["stepping_s"]
                row["time_ratio"] = row["stepping_s"] / base
                row["speedup"] = base / row["stepping_s"]
                rows.append(row)
                print(f"sweep: n={n} {treat} eta={eta}: {row['stepping_s']:.3f} s, max rel error "
                      f"{row['max_rel_error']:.3e}", flush=True)
    fields = list(dict.fromkeys(k for r in rows for k in r))
    with open(out / "sweep.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)
    table = markdown(rows)
    (out / "sweep.md").write_text(f"{scene.name}: coarse partition '{coarse}' at η x time.dt\n\n"
                                  f"{table}\n")
    plot(rows, out / "sweep.png", f"{scene.name}: error and run time against step ratio η")
    print(table)
    print(f"sweep: wrote {out}/sweep.csv, sweep.md, sweep.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
