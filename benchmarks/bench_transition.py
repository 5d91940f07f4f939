"""Zhang et al. (2009) Table 1 in form: the transition zone against the overlap coupling.

    ./run.sh bench     (or: python benchmarks/bench_transition.py [--quick])

All runs load the bar of Zhang et al. (2009) §2 with the sudden load and unload
(1.0e4 N/m for 1.5e-5 s), stiffness-proportional damping beta = 2e-8 s, the
same DE step (1.4e-8 s) and end time (7.5e-5 s), on 1 rank in this process:

- space multiscale: ``configs/wave_bar.yaml`` (overlap scheme, eta = 1; FE
  cells as fine as the lattice, 0.2 mm);
- time and space multiscale: ``configs/wave_bar_transition.yaml`` with 2, 3,
  4, 5 particle layers in the band (band and FE cells (layers - 1) x 0.2 mm)
  and FE step ratio 1, 2, 3, 4 (Zhang et al. 2009, Table 1);
- the 5-layer mesh at ratio 1 (what the time multiscale alone buys), the band
  motions ``linear``, ``velocity`` and ``hold`` against the default
  ``predictor`` (``velocity`` and ``hold`` at the shorter DE steps their
  stable FE steps allow, and ``velocity`` refused at the common one), the
  same mesh FEM-only (the coarse mesh's own error), an extreme case with
  particles 10x finer than the coarse cells (0.08 mm in 0.8 mm cells, ratio
  10), and a lattice 10x stiffer than the FE material (at a DE step it allows,
  and at the common one, which the guard refuses naming both critical steps).
  The 1D solution assumes one material: with the stiff lattice the errors at
  B and C include the physical reflections at the impedance jumps.
- like for like (Zhang et al. kept their FE mesh fixed): 0.8 mm FE cells in
  every run and only the band changes, 2, 3, 4, 5 layers at FE step ratio 1,
  2, 3, 4 (``model.mesh_parameters.h=8e-4``), timed against the 2-layer band
  at ratio 1, in a second table.  The first table's time ratios are against the
  space-multiscale run, whose FE cells are 0.2 mm: they include the coarser
  mesh as well as the larger step.

For each: DE count, FE cell count, steps, stepping wall time and its ratio to
the space-multiscale run, stress arrival (50 % crossing, % of the travel time)
and peak errors at A, B, C against the 1D solution, and the energy crossing A
after the incident pulse (left-going: reflected by the interfaces, plus the
mesh's dispersion tail) relative to the incident energy.  Writes
results/bench_transition.md and results/bench_transition.png (stress at A, B,
C: Zhang et al. (2009) Fig. 4).
"""
from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from solver import scene as scene_mod

from solver.model import binding
from solver.errors import RunFailed, SolverError
from solver.petscutil import init

import tables                  # noqa: E402  (benchmarks/tables.py, beside this script)

PROBES = ("A", "B", "C")
COMMON = ["time.dt=1.4e-8", "damping.beta=2e-8", "output.progress=0"]
PULSE = ("loads=[{group: left, kind: rectangular, amplitude: 1.0e4, duration: 1.5e-5, "
         "direction: [1.0, 0.0]}]")


def transition(layers, ratio, *more):
    """The config at ``layers`` and FE step ``ratio`` x the DE step, to the last
    whole system step at or before 75 us (a run ends on a system step)."""
    dt = float(next((m.split("=")[1] for m in more if m.startswith("time.dt=")), 1.4e-8))
    end = int(7.5e-5 / (ratio * dt) + 1e-9) * ratio * dt
    return ("configs/wave_bar_transition.yaml",
            [f"model.mesh_parameters.layers={layers}", f"partitions.fem.ratio={ratio}",
             f"time.end={end:.12g}", *more])


RUNS = [("space multiscale (overlap)", "-", 1, ("configs/wave_bar.yaml",
                                                [PULSE, f"time.end={5357 * 1.4e-8:.12g}"]))] + \
    [(f"transition, {n} layers", n, n - 1, transition(n, n - 1)) for n in (2, 3, 4, 5)] + \
    [("transition, 5 layers, ratio 1", 5, 1, transition(5, 1)),
     ("5 layers, band_motion linear", 5, 4, transition(5, 4, "coupling.band_motion=linear")),
     ("5 layers, band_motion velocity", 5, 4, transition(5, 4, "coupling.band_motion=velocity")),
     ("band_motion velocity, DE step 8.3e-9 s", 5, 4, transition(
         5, 4, "coupling.band_motion=velocity", "time.dt=8.3e-9")),
     ("band_motion hold, DE step 2.5e-9 s", 5, 4, transition(
         5, 4, "coupling.band_motion=hold", "time.dt=2.5e-9")),
     ("FEM only, 5-layer mesh", "-", 1, transition(
         5, 1, "model.lattice=null", "coupling.scheme=overlap",
         "partitions=[{name: fem, method: fem, group: solid, integrator: explicit, ratio: 1}]")),
     ("particles 10x finer (0.08 mm)", 11, 10, transition(
         11, 10, "model.mesh_parameters.a=8e-5", "model.lattice.spacing=8e-5", "time.dt=3.7e-9")),
     ("lattice 10x stiffer (E = 700 GPa)", 5, 4, transition(
         5, 4, "model.lattice.E=7e11", "time.dt=3e-9")),
     ("lattice 10x stiffer, DE step 1.4e-8 s", 5, 4, transition(5, 4, "model.lattice.E=7e11"))]


FIXED = [(f"0.8 mm FE cells, {n} layers", n, n - 1,
          transition(n, n - 1, "model.mesh_parameters.h=8e-4")) for n in (2, 3, 4, 5)]


def reflected(res):
    """Energy flux past A after the incident pulse over the incident one (v^2 at A)."""
    t, v = res.probes["A"]["t"], res.probes["A"]["velocity"]
    inc, after = (t >= 10e-6) & (t <= 32e-6), (t > 32e-6) & (t <= 75e-6)
    return np.trapezoid(v[after] ** 2, t[after]) / np.trapezoid(v[inc] ** 2, t[inc])


HEADER = ["| run | layers | FE step ratio | DEs | FE cells | DE step [s] | FE steps | DE steps | "
          "stepping wall [s] | time ratio | stress arrival error A / B / C [%] | stress peak "
          "error A / B / C [%] | energy after the pulse at A |",
          "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="only the Table 1 rows")
    ap.add_argument("--fixed", action="store_true", help="only the like-for-like table")
    args = ap.parse_args(argv)
    init([])
    tmp = Path(tempfile.mkdtemp())
    if args.fixed:
        lines = [*HEADER]
        rows(FIXED, lines, tmp, {})
        tables.write("bench_transition_fixed", lines, doc=False)
        return
    lines = ["# Zhang et al. (2009) Table 1 in form: transition zone against the overlap coupling", "",
             "Same DE step 1.4e-8 s, 5357 DE steps to 7.5e-5 s, rectangular pulse, "
             "beta = 2e-8 s; 1 rank.  Zhang et al. (2009): 84 DEs, DE step 5e-9 s, 21,000 steps; "
             "127.21 s (space) and 56.97 / 50.39 / 45.83 s (ratio 2 / 3 / 4): 0.36 at 5 layers, "
             "with the FE mesh fixed.", "",
             "Space and time multiscale: the FE cells grow with the band ((layers - 1) x 0.2 mm); "
             "time ratio against the space-multiscale run (0.2 mm FE cells), so it includes the "
             "coarser mesh.", "", *HEADER]
    curves = {}
    rows(RUNS[:5] if args.quick else RUNS, lines, tmp, curves)
    lines += ["", "Like for like (the paper's Table 1 keeps its FE mesh): 0.8 mm FE cells in every "
              "run, only the band and the step ratio change; time ratio against the 2-layer band "
              "at ratio 1.", "", *HEADER]
    rows(FIXED, lines, tmp, {})
    out = tables.write("bench_transition", lines, doc=not args.quick)
    plot(curves, out.with_suffix(".png"))


def rows(runs, lines, tmp, curves):
    """Run ``runs`` and add their table rows to ``lines``; the time ratio is
    against the first run; ``curves`` gets the stress histories to plot."""
    from mpi4py import MPI

    from solver.driver.runner import run
    t_ref = None
    for label, layers, ratio, (path, sets) in runs:
        try:
            scene = binding.load(path, COMMON + sets + [f"output.file={tmp}/r{len(lines)}.h5"])
            res = run(scene, MPI.COMM_SELF, log=lambda *x: None)
        except (RunFailed, SolverError) as e:
            lines.append(f"| {label} | {layers} | {ratio} | - | - | - | - | - | - | - | "
                         f"{str(e).split(': ', 1)[-1][:120]} | - | - |")
            print(lines[-1], flush=True)
            continue
        wall = res.attrs["stepping_wall_time"]
        t_ref = t_ref or wall
        steps = {k: p["steps"] for k, p in res.partitions.items()}
        mdl_cells = res.attrs.get("fe_cells", "-")
        n_de = res.attrs.get("particles", res.partitions.get("dem", {}).get("n_owned", "-"))
        at = {p: res.probes[p]["attrs"] for p in PROBES}

        def per_probe(key):
            return " / ".join(f"{100 * at[p][key]:+.2f}" for p in PROBES)
        lines.append(
            f"| {label} | {layers} | {ratio} | {n_de} | {mdl_cells} | {scene.time.dt:.2g} | "
            f"{steps['fem']} | "
            f"{steps.get('dem', '-')} | {wall:.3f} | {wall / t_ref:.3f} | "
            f"{per_probe('stress_arrival_error')} | {per_probe('stress_peak_error')} | "
            f"{reflected(res):.2e} |")
        print(lines[-1], flush=True)
        if label.startswith(("space", "transition, 5 layers", "transition, 2")) and \
                "ratio 1" not in label:
            curves[label] = {p: (res.probes[p]["t"], res.probes[p]["stress"],
                                 res.probes[p].get("reference_stress")) for p in PROBES}


def plot(curves, path):
    """Zhang et al. (2009) Fig. 4: stress at A, B, C against time, 1D solution dashed."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(3, 1, figsize=(7, 7.5), sharex=True)
    for ax, p in zip(axes, PROBES):
        ref_done = False
        for i, (label, probes) in enumerate(curves.items()):
            t, s, ref = probes[p]
            ax.plot(t * 1e6, s / 1e6, color=f"C{i}", lw=1, label=label)
            if ref is not None and not ref_done:
                ax.plot(t * 1e6, ref / 1e6, "k--", lw=1, label="1D solution")
                ref_done = True
        ax.set_ylabel(f"σxx at {p} [MPa]")
    axes[0].legend(fontsize=7, loc="lower right")
    axes[-1].set_xlabel("t [µs]")
    fig.suptitle("wave_bar: stress at A (FE), B (DEM), C (FE)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    main()
