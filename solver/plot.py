"""Plot a run's HDF5 output: probe histories against the reference, their
error, and the energy balance.

    python -m solver.plot results/six_dof.h5 [-o results/six_dof.png]

(``./run.sh plot FILE``).  Works on failed runs too: it shows where they stopped.
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


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m solver.plot", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("file")
    ap.add_argument("-o", "--out")
    args = ap.parse_args(argv)
    if not Path(args.file).is_file():
        print(f"error: {args.file}: no such output file", file=sys.stderr)
        return 2
    out = figure(args.file, args.out or str(Path(args.file).with_suffix(".png")))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
