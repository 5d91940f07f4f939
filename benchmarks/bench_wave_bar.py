"""wave_bar (Zhang et al. 2009, §2): FEM-only against coupled runs, like Zhang et al. (2009) Table 1.

    ./run.sh bench     (or: python benchmarks/bench_wave_bar.py [--spacing 2e-4])

Runs, in this process on 1 rank: the FEM-only bar, the coupled FEM-DEM bar at
eta = 1 (explicit FEM, concurrent scheme), at eta = 2, 3, 10 (implicit FEM,
staggered scheme; the explicit FEM partition has the DEM's critical step since
the mesh is as fine as the lattice at the interfaces) and at eta = 10, 20, 30,
50 with the energy-conserving scheme (docs/conserving.md).  For each: stepping wall
time and its ratio to the FEM-only run, the arrival-time and peak errors at
A, B, C against the 1D wave (x/c, sigma/(rho c)), and the energy crossing A
after the incident pulse (left-going: reflected at the interfaces plus the
mesh's dispersion tail) relative to the incident energy.
"""
from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from solver import scene as scene_mod

from solver.model import binding
from solver.errors import RunFailed
from solver.petscutil import init

import tables                  # noqa: E402  (benchmarks/tables.py, beside this script)

E, RHO, THICK, Q, T = 70e9, 2700.0, 3.2e-4, 1.0e4, 1.5e-5
C = np.sqrt(E / RHO)
V0 = (Q / THICK) / (RHO * C)
PROBES = {"A": 0.078, "B": 0.160, "C": 0.242}
RUNS = [("FEM only", ["partitions=[{name: fem, method: fem, group: solid, integrator: explicit, "
                      "ratio: 1}]"], "explicit", 1),
        ("coupled, overlap", [], "explicit", 1),
        *[(f"coupled, {scheme}", ["partitions.fem.integrator=implicit", f"partitions.fem.ratio={eta}",
                                  f"coupling.scheme={scheme}"], "implicit", eta)
          for scheme, eta in (("staggered", 2), ("staggered", 3), ("staggered", 10),
                              ("conserving", 10), ("conserving", 20), ("conserving", 30),
                              ("conserving", 50))]]


def metrics(res):
    out = {}
    for name, x in PROBES.items():
        pr = res.probes[name]
        t, v = pr["t"], pr["velocity"]
        peak = v.max()
        k = int(np.argmax(v >= 0.5 * peak))
        half = t[k - 1] + (0.5 * peak - v[k - 1]) / (v[k] - v[k - 1]) * (t[k] - t[k - 1])
        out[name] = (100 * ((half - T / 6) / (x / C) - 1), 100 * (peak / V0 - 1))
    t, v = res.probes["A"]["t"], res.probes["A"]["velocity"]
    inc, after = (t >= 10e-6) & (t <= 32e-6), (t > 32e-6) & (t <= 77e-6)
    out["reflected"] = np.trapezoid(v[after] ** 2, t[after]) / np.trapezoid(v[inc] ** 2, t[inc])
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--spacing", type=float, default=2e-4, help="lattice spacing = element size [m]")
    args = ap.parse_args(argv)
    init([])
    from mpi4py import MPI

    from solver.driver.runner import run
    a = args.spacing
    tmp = Path(tempfile.mkdtemp())
    base = [f"model.mesh_parameters.a={a}", f"model.lattice.spacing={a}", f"time.dt={a * 1e-4}",
            "output.progress=0"]
    lines = [f"# wave_bar, lattice spacing = element size {a * 1e3:g} mm, base step {a * 1e-4:.2g} s",
             "", "| run | FEM integrator | η | FEM steps | DEM steps | stepping wall [s] | time ratio | "
             "arrival error A / B / C [%] | peak error A / B / C [%] | energy after the pulse at A |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    t_ref = None
    for i, (label, sets, integ, eta) in enumerate(RUNS):
        scene = binding.load("configs/wave_bar.yaml", base + sets + [f"output.file={tmp}/r{i}.h5"])
        try:
            res = run(scene, MPI.COMM_SELF, log=lambda *x: None)
        except RunFailed as e:
            lines.append(f"| {label} | {integ} | {eta} | - | - | - | - | unstable: "
                         f"{str(e).split(': ', 1)[1].split(', above')[0].split('; output')[0]} | - | - |")
            print(lines[-1], flush=True)
            continue
        wall = res.attrs["stepping_wall_time"]
        t_ref = t_ref or wall
        m = metrics(res)
        steps = {k: p["steps"] for k, p in res.partitions.items()}
        lines.append(f"| {label} | {integ} | {eta} | {steps['fem']} | {steps.get('dem', '-')} | "
                     f"{wall:.2f} | {wall / t_ref:.2f} | "
                     f"{' / '.join(f'{m[p][0]:+.2f}' for p in PROBES)} | "
                     f"{' / '.join(f'{m[p][1]:+.2f}' for p in PROBES)} | {m['reflected']:.2e} |")
        print(lines[-1], flush=True)
    tables.write("bench_wave_bar", lines, doc=args.spacing == 2e-4)


if __name__ == "__main__":
    main()
