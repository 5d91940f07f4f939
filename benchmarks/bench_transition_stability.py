"""Where the transition scheme is stable: the spectral radius of its system step.

    python benchmarks/bench_transition_stability.py [--quick]

The scheme is linear, so one system step is a matrix G acting on the owned
(u, v, a) of both partitions.  This script builds a short bar (9.6 mm, the
DEM region 4.8 mm in the middle; configs/wave_bar_transition.yaml otherwise,
no loads) through the project's own build, applies one system step to every
unit state to get G's columns, and bisects on the FE step for the largest
one with spectral radius <= 1 + 1e-7.  Cases: band width (layers), step
ratio N (1: no sub-cycling), damping, a lattice 10x stiffer than the FE
material, and the band motions.  The stable limit is given
as omega_max * fdt, omega_max being the FE partition's own (band masses and
carried bonds included, core particles held): what the guard checks
(solver/partitions/stability.py, TRANSITION_OMEGA_H).  Writes
results/bench_transition_stability.md.
"""
from __future__ import annotations

import argparse
import copy
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from solver import scene as scene_mod                    # noqa: E402
from solver.petscutil import init                        # noqa: E402

import tables                  # noqa: E402  (benchmarks/tables.py, beside this script)

SLOW = True                    # about 40 min: ./run.sh bench --all


def short_bar(layers, ratio, dt, beta_r, lattice_E=None, newmark_beta=0.0, motion="predictor"):
    from solver.scene.file import anchor_paths
    from solver.scene import yaml_load
    root = Path(__file__).resolve().parents[1] / "configs"
    raw = anchor_paths(yaml_load((root / "wave_bar_transition.yaml").read_text()), root)
    raw["model"]["mesh_parameters"] = {"layers": layers, "L": 0.0096, "x1": 0.0024, "x2": 0.0072}
    if lattice_E:
        raw["model"]["lattice"]["E"] = lattice_E
    raw["partitions"][0].update(ratio=ratio, beta=newmark_beta)
    raw["coupling"]["band_motion"] = motion
    raw.update(time={"end": max(round(1e-6 / (ratio * dt)), 1) * ratio * dt, "dt": dt}, guard={"stable_step": False}, reference="none",
               probes=[], loads=[], damping={"beta": beta_r},
               output={"file": "/tmp/bench_transition_stability.h5"})
    if not beta_r:
        raw.pop("damping")
    return raw


def radius(raw):
    """(spectral radius of one system step, FE omega_max, DEM omega_max)."""
    from mpi4py import MPI

    from solver.driver.build import build
    from solver.model import binding
    asm = build(binding.bind(scene_mod.from_dict(copy.deepcopy(raw))), MPI.COMM_SELF)
    from solver.coupling.analysis import spectral_radius, step_matrix
    scheme, parts = asm.scheme, asm.parts
    scheme.initialise(asm.model)
    rho = spectral_radius(step_matrix(scheme, parts))
    om = {p.name: asm.scheme.freqs[p.name][0].omega_max for p in parts}
    asm.destroy()
    return rho, om["fem"], om["dem"]


def limit(layers, ratio, beta_r, lattice_E=None, newmark_beta=0.0, motion="predictor", steps=8):
    """Largest stable FE step (bisection on the DE step), as omega_fe * fdt."""
    def bar(dt):
        return short_bar(layers, ratio, dt, beta_r, lattice_E, newmark_beta, motion)
    _, om_fe, om_de = radius(bar(1e-10))
    lo, hi = 0.02 / om_fe / ratio, min(2.2 / om_fe / ratio, 1.999 / om_de)
    r_lo = radius(bar(lo))[0]
    if r_lo > 1 + 1e-7:
        return om_fe, om_de, None, r_lo
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        if radius(bar(mid))[0] <= 1 + 1e-7:
            lo = mid
        else:
            hi = mid
    return om_fe, om_de, ratio * lo * om_fe, r_lo


CASES = [  # layers, ratio, damping beta [s] or "xi" (0.01 at the DEM's omega_max), lattice E, Newmark beta
    # (the FE's Newmark beta must be 0 in a scene: see tests/test_transition.py)
    (5, 4, 0.0, None, 0.0),
    (5, 4, "xi", None, 0.0),
    (5, 4, 1e-9, None, 0.0),
    (5, 4, 2e-8, None, 0.0),
    (5, 1, 0.0, None, 0.0),
    (5, 2, 1e-9, None, 0.0),
    (5, 8, 1e-9, None, 0.0),
    (4, 3, 1e-9, None, 0.0),
    (3, 2, "xi", None, 0.0),
    (3, 2, 1e-9, None, 0.0),
    (5, 4, 1e-9, 7e11, 0.0),
    (5, 4, 1e-9, None, 0.0, "linear"),
    (5, 4, 1e-9, None, 0.0, "velocity"),
    (5, 4, 1e-9, None, 0.0, "hold"),
    (5, 4, "xi", None, 0.0, "linear"),
    (5, 4, "xi", None, 0.0, "velocity"),
    (5, 4, "xi", None, 0.0, "hold"),
]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="three cases")
    ap.add_argument("--only", type=int, nargs="*", help="case numbers (0-based) to run")
    args = ap.parse_args(argv)
    init([])
    lines = ["# Transition scheme: stable FE steps from the spectral radius of a system step", "",
             "Produced by `python benchmarks/bench_transition_stability.py` (each case: `--only N`).",
             "Short bar (9.6 mm, DEM region 4.8 mm, lattice 0.2 mm), no loads; largest stable FE "
             "step as omega_max * fdt (omega_max: the FE partition's own).  The guard allows "
             "omega_max * fdt < 1.15 (predictor, linear), 0.65 (velocity), 0.2 (hold) and asks for "
             "a damping ratio >= 0.01 at the DEM's highest "
             "frequency when the DEM sub-cycles.", "",
             "| layers | ratio N | damping beta [s] | lattice E | band motion | FE omega_max "
             "[rad/s] | DEM omega_max [rad/s] | radius - 1 at the smallest step | stable up to "
             "omega_max * fdt |", "|---|---|---|---|---|---|---|---|---|"]
    cases = [CASES[i] for i in args.only] if args.only else \
        (CASES[:2] + CASES[8:9] if args.quick else CASES)
    for layers, ratio, beta_r, E, nb, *motion in cases:
        motion = motion[0] if motion else "predictor"
        if beta_r == "xi":
            _, _, om_de = radius(short_bar(layers, ratio, 1e-10, 0.0, E, nb))
            beta_r = 2 * 0.01 / om_de
        om_fe, om_de, lim, r_lo = limit(layers, ratio, beta_r, E, nb, motion)
        lines.append(f"| {layers} | {ratio} | {beta_r:.3g} | {E or 'material'} | {motion} | "
                     f"{om_fe:.4g} | {om_de:.4g} | {r_lo - 1:+.1e} | "
                     f"{'unstable at every step' if lim is None else f'{lim:.3f}'} |")
        print(lines[-1], flush=True)
    tables.write("bench_transition_stability", lines, doc=not (args.quick or args.only))


if __name__ == "__main__":
    main()
