"""Plot a run's HDF5 output: probe histories against the reference, their
error, and the energy balance.

    python -m solver.tools.plot results/six_dof.h5 [-o results/six_dof.png]
    python -m solver.tools.plot A.h5 B.h5 [...] --probe p550 -o compare.png

(``./run.sh plot ...``).  Works on failed runs too: it shows where they stopped.
Panels: probe displacements (with the reference), their error, stress at
continuum probes, energies (with the damping's dissipation), the largest
temperature (heat); only those the file has data for.  ``-o`` into a missing
directory creates it.
With several files it overlays one probe of each, normalised by its largest
displacement (Li et al. 2023, Fig. 8: the metamaterial chain with and without
resonators).
"""
from __future__ import annotations

import argparse
import sys
import textwrap
from pathlib import Path

import h5py
import numpy as np


AXES = "xyz"


def quantity(pr, what: str = "u") -> str:
    """'u_x' / 'sigma_xx' of a probe (networks: 'u', their DOFs have no axis)."""
    comp = int(pr["attrs"].get("component", 0))
    if "coordinates" not in pr["attrs"]:                       # a network's DOF
        return what
    axis = AXES[comp] if comp < 3 else f"r{AXES[comp - 3]}"    # shells: rotations 3-5
    return f"{what}_{axis}" if what == "u" else f"σ_{axis}{axis}"


def panels_of(probes, energy, heat) -> list[str]:
    """The panels a file has data for, in order (none empty: a heat-only run's
    energies are all zero and get none)."""
    out = []
    if probes:
        out.append("displacement")
        if any("reference_displacement" in pr for pr in probes.values()):
            out.append("error")
        if any("stress" in pr for pr in probes.values()):
            out.append("stress")
    if any(np.any(v) for k, v in energy.items() if k != "t"):     # not a heat-only run's zeros
        out.append("energy")
    if heat and len(heat.get("t", ())):
        out.append("heat")
    return out


def figure(path: str, out: str) -> str:
    import matplotlib  # lazy: matplotlib loads only for plots
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # lazy: matplotlib loads only for plots
    with h5py.File(path, "r") as f:
        a = dict(f.attrs)
        probes = {name: {k: g[k][()] for k in g} | {"attrs": dict(g.attrs)}
                  for name, g in f.get("probes", {}).items()}
        energy = {k: f["energy"][k][()] for k in f.get("energy", {})}
        heat = {k: f["heat"][k][()] for k in f["heat"]} if "heat" in f else {}
    panels = panels_of(probes, energy, heat)
    fig, axes = plt.subplots(len(panels), 1, figsize=(9, 2.6 + 2.3 * len(panels)), sharex=True,
                             squeeze=False)
    ax = dict(zip(panels, axes[:, 0]))
    units = {"displacement": "m", "stress": "Pa"}
    for i, (name, pr) in enumerate(probes.items()):
        t, q = pr["t"], quantity(pr)
        rot = q.startswith("u_r")
        ax["displacement"].plot(t, pr["displacement"], color=f"C{i}",
                                label=f"{name}: {q} ({pr['attrs']['partition']})")
        if "reference_displacement" in pr:
            ref = pr["reference_displacement"]
            ax["displacement"].plot(t, ref, color=f"C{i}", ls=":", lw=1.2,
                                    label=f"{name}: {q} reference")
            at = pr["attrs"]
            label = (f"{name}: max rel. {at['max_rel_error']:.2e}, RMS rel. {at['rms_rel_error']:.2e}"
                     if np.isfinite(at.get("max_rel_error", np.nan)) else
                     f"{name}: reference zero, max |error| {at.get('max_abs_error', np.nan):.2e}")
            ax["error"].plot(t, pr["displacement"] - ref, color=f"C{i}", label=label)
        if "stress" in pr:
            s = quantity(pr, "sigma")
            ax["stress"].plot(t, pr["stress"], color=f"C{i}", label=f"{name}: {s}")
            if "reference_stress" in pr:
                ax["stress"].plot(t, pr["reference_stress"], color=f"C{i}", ls=":", lw=1.2,
                                  label=f"{name}: {s} reference")
    if probes:
        unit = "rad" if all(quantity(pr).startswith("u_r") for pr in probes.values()) else "m"
        ax["displacement"].set_ylabel(f"displacement [{unit}]")
    if "error" in ax:
        ax["error"].set_ylabel("displacement − reference [m]")
        ax["error"].set_title("error against the reference "
                              "(max rel.: max|u − u_ref| / max|u_ref|; RMS rel.: "
                              "‖u − u_ref‖₂ / ‖u_ref‖₂)", fontsize=9)
    if "stress" in ax:
        ax["stress"].set_ylabel(f"stress [{units['stress']}]")
    if "energy" in ax:
        e = ax["energy"]
        dissipated = energy.get("dissipated")
        for key in ("kinetic", "strain", "total", "external_work"):
            if key in energy:
                e.plot(energy["t"], energy[key], label=key.replace("_", " "),
                       ls="--" if key == "external_work" else "-")
        if dissipated is not None and np.any(dissipated):
            e.plot(energy["t"], dissipated, label="dissipated (damping)")
            e.plot(energy["t"], energy["total"] + dissipated, ls=":",
                   label="total + dissipated (= external work when balanced)")
        e.set_ylabel("energy [J]")
    if "heat" in ax:
        h = ax["heat"]
        h.plot(heat["t"], heat["max_temperature"], color="C3",
               label=f"largest temperature (heating time at the end: "
                     f"{heat['heating_time'][-1]:.3g} s)" if "heating_time" in heat
               else "largest temperature")
        h.set_ylabel("temperature [K]")
    for panel, axis in ax.items():
        axis.grid(alpha=0.3)
        if axis.lines:
            axis.legend(fontsize=8)
    if panels:
        axes[-1, 0].set_xlabel("t [s]")
    status = a["status"] if a["status"] == "completed" else f"{a['status']}: {a['message']}"
    title = (f"{a['scene']} — {a.get('scheme', '?')} scheme, {a['external_treatment']} treatment, "
             f"system step {a['system_dt']:.3g} s, {a['ranks']} rank(s), {status}")
    fig.suptitle(textwrap.fill(title, 100), fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def compare(paths, probe, out) -> str:
    import matplotlib  # lazy: matplotlib loads only for plots
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # lazy: matplotlib loads only for plots
    fig, ax = plt.subplots(figsize=(9, 4.5))
    for path in paths:
        with h5py.File(path, "r") as f:
            name = probe or next(iter(f["probes"]))
            g = f[f"probes/{name}"]
            t, u = g["t"][()], g["displacement"][()]
            label = f"{f.attrs['scene']} ({name}: {quantity({'attrs': dict(g.attrs)})})"
        peak = np.abs(u).max() or 1.0
        ax.plot(1e3 * t, u / peak, label=f"{label}, max |u| = {peak:.3g} m")
    ax.set(xlabel="t [ms]", ylabel="displacement / max displacement",
           title="probe histories, each normalised by its own peak")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def check(path: str, probe: str | None, several: bool = False) -> str | None:
    """Why ``path`` cannot be plotted (missing, not HDF5, truncated, not a
    solver output, no such probe, no probes to compare), or None.  A run
    without probes (heat only, configs/laser_disc.yaml) plots its energies
    and temperatures."""
    if not Path(path).is_file():
        return "no such output file"
    try:
        with h5py.File(path, "r") as f:
            missing = [m for m in ("/energy", "status attribute")
                       if (m[1:] not in f if m.startswith("/") else "status" not in f.attrs)]
            if missing:
                return f"not an output of this solver (no {', '.join(missing)})"
            have = sorted(f.get("probes", {}))
            if probe is not None and probe not in have:
                return f"no probe {probe!r} (it has: {', '.join(have) or 'none'})"
            if several and not have:
                return "has no probes to compare (the scene had none)"
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
    several = len(args.files) > 1
    for path in args.files:
        problem = check(path, args.probe, several)
        if problem:
            print(f"error: {path}: {problem}", file=sys.stderr)
            return 2
    out = args.out or ("compare.png" if several else str(Path(args.files[0]).with_suffix(".png")))
    try:                                    # -o into a missing directory: it is made
        Path(out).resolve().parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        print(f"error: -o {out}: cannot create its directory ({e.strerror or e})", file=sys.stderr)
        return 2
    if Path(out).is_dir():
        print(f"error: -o {out}: is a directory", file=sys.stderr)
        return 2
    if several:
        out = compare(args.files, args.probe, out)
    else:
        out = figure(args.files[0], out)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
