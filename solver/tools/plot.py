"""Plot a run's HDF5 output: probe histories against the reference, their
error, and the energy balance.

    python -m solver.tools.plot results/six_dof.h5 [-o results/six_dof.png]
    python -m solver.tools.plot A.h5 B.h5 [...] --probe p550 -o compare.png

(``./run.sh plot ...``).  Works on failed runs too: it shows where they stopped.
With several files it overlays one probe of each, normalised by its largest
displacement (seed 000 Fig. 8: the metamaterial chain with and without
resonators).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import h5py
import numpy as np


def figure(path: str, out: str) -> str:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    with h5py.File(path, "r") as f:
        a = dict(f.attrs)
        probes = {name: {k: g[k][()] for k in g} | {"attrs": dict(g.attrs)}
                  for name, g in f["probes"].items()}
        energy = {k: f["energy"][k][()] for k in f["energy"]}
    fig, (ax0, ax1, ax2) = plt.subplots(3, 1, figsize=(9, 9), sharex=True)
    for i, (name, pr) in enumerate(probes.items()):
        t = pr["t"]
        ax0.plot(t, pr["displacement"], color=f"C{i}", label=f"{name} ({pr['attrs']['partition']})")
        if "reference_displacement" in pr:
            ref = pr["reference_displacement"]
            ax0.plot(t, ref, color="k", ls=":", lw=1, label=f"{name} reference ({a['reference']})")
            at = pr["attrs"]
            ax1.plot(t, pr["displacement"] - ref, color=f"C{i}",
                     label=f"{name}: max rel. {at['max_rel_error']:.2e}, RMS rel. "
                           f"{at['rms_rel_error']:.2e}")
    ax0.set_ylabel("displacement")
    ax0.legend(fontsize=8)
    ax1.set_ylabel("displacement - reference")
    if ax1.lines:
        ax1.legend(fontsize=8)
    else:
        ax1.text(0.5, 0.5, "no reference in this run", transform=ax1.transAxes, ha="center")
    for key in ("kinetic", "strain", "total", "external_work"):
        ax2.plot(energy["t"], energy[key], label=key.replace("_", " "),
                 ls="--" if key == "external_work" else "-")
    ax2.set_ylabel("energy [J]")
    ax2.set_xlabel("t [s]")
    ax2.legend(fontsize=8)
    for ax in (ax0, ax1, ax2):
        ax.grid(alpha=0.3)
    status = a["status"] if a["status"] == "completed" else f"{a['status']}: {a['message']}"
    fig.suptitle(f"{a['scene']} — {a['external_treatment']} treatment, system step "
                 f"{a['system_dt']:.3g} s, {a['ranks']} rank(s), {status}", fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def compare(paths, probe, out) -> str:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(9, 4.5))
    for path in paths:
        with h5py.File(path, "r") as f:
            name = probe or next(iter(f["probes"]))
            g = f[f"probes/{name}"]
            t, u = g["t"][()], g["displacement"][()]
            label = f"{f.attrs['scene']} ({name})"
        peak = np.abs(u).max() or 1.0
        ax.plot(1e3 * t, u / peak, label=f"{label}, max |u| = {peak:.3g}")
    ax.set(xlabel="t [ms]", ylabel="displacement / max displacement",
           title="probe histories, each normalised by its own peak")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def check(path: str, probe: str | None) -> str | None:
    """Why ``path`` cannot be plotted (missing, not HDF5, truncated, not a
    solver output, no such probe), or None."""
    if not Path(path).is_file():
        return "no such output file"
    try:
        with h5py.File(path, "r") as f:
            missing = [k for k in ("probes", "energy") if k not in f]
            if missing or "status" not in f.attrs:
                what = ", ".join("/" + m for m in missing) or "status attribute"
                return f"not an output of this solver (no {what})"
            if probe is not None and probe not in f["probes"]:
                have = ", ".join(sorted(f["probes"])) or "none"
                return f"no probe {probe!r} (it has: {have})"
    except OSError as e:
        return f"not a readable HDF5 file ({' '.join(str(e).split())[:160]})"
    return None


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m solver.tools.plot", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("files", nargs="+")
    ap.add_argument("-o", "--out")
    ap.add_argument("--probe", help="probe to compare across files (default: each file's first)")
    args = ap.parse_args(argv)
    for path in args.files:
        problem = check(path, args.probe)
        if problem:
            print(f"error: {path}: {problem}", file=sys.stderr)
            return 2
    if len(args.files) > 1:
        out = compare(args.files, args.probe, args.out or "compare.png")
    else:
        out = figure(args.files[0], args.out or str(Path(args.files[0]).with_suffix(".png")))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
