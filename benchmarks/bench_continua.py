"""The continuum options of a real part against their exact or reference
solutions: a bar struck by a bar (initial.motion), a bar driven at one end
(model.prescribed), a column hanging under its weight (gravity, static), a
near-incompressible cantilever (model.integration), and each integration's
stable step as the guard applies it.

    python benchmarks/bench_continua.py        (part of ./run.sh bench, ~30 s)

Bars: meshes/wave_bar.geo (configs/wave_bar_fem.yaml's aluminium strip,
0.32 m x 2.4 mm x 0.32 mm, plane stress, 1605 nodes), explicit, dt 20 ns.
Cantilever: meshes/cantilever.geo (0.1 x 0.01 m, plane strain, E 1 GPa,
nu 0.4999, 40 x 4 quad4 cells), tip shear, static, against Timoshenko's
beam (bending with E / (1 - nu^2) plus shear with kappa 5/6).
Writes docs/benchmarks/bench_continua.md.
"""
from __future__ import annotations

import copy
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))
import solver  # noqa: E402  (first: one BLAS thread, as in the solver)

from tables import write  # noqa: E402
from solver.errors import SceneError  # noqa: E402

E, RHO, THICK, H, L = 70e9, 2700.0, 3.2e-4, 2.4e-3, 0.32
C = (E / RHO) ** 0.5
OUT = Path(tempfile.mkdtemp()) / "continua.h5"


def run(raw):
    """RunResult of scene data ``raw`` (one rank, silent); a refused scene raises."""
    from mpi4py import MPI
    raw = copy.deepcopy(raw)
    raw["output"] = {"file": str(OUT), "progress": 0}
    return solver.run(solver.scene_from_dict(raw), comm=MPI.COMM_SELF, overwrite=True)


def bar(end, **over):
    """The free aluminium strip, no load."""
    raw = {"name": "bar", "time": {"end": end, "dt": 2.0e-8},
           "model": {"kind": "continuum", "mesh": str(ROOT / "meshes" / "wave_bar.geo"),
                     "material": {"E": E, "nu": 0.33, "rho": RHO, "kind": "plane_stress",
                                  "thickness": THICK},
                     "body": "solid"},
           "partitions": [{"name": "fem", "method": "fem", "group": "solid",
                           "integrator": "explicit", "ratio": 1}],
           "probes": [{"name": "ahead", "at": [0.2, 0.0012]}, {"name": "behind", "at": [0.12, 0.0012]}]}
    raw.update(over)
    return raw


def plateau(pr, after):
    keep = pr["t"] > after
    return float(pr["velocity"][keep].mean()), float(pr["stress"][keep].mean())


def struck():
    v = 2.0
    res = run(bar(2.0e-5, initial={"motion": [{"velocity": [f"{v} * (x < 0.1595)", 0]}]}))
    arrive = 0.04 / C                                  # both probes 40 mm from the contact
    rows = []
    for name, where in (("ahead", "ahead of"), ("behind", "behind")):
        vel, sig = plateau(res.probes[name], 1.5 * arrive)
        rows.append((f"struck bar (v = 2 m/s), 40 mm {where} the contact: particle velocity "
                     "(1D: v/2)", vel, v / 2))
        rows.append((f"struck bar, 40 mm {where} the contact: stress (-rho c v/2)", sig,
                     -RHO * C * v / 2))
    return rows


def driven():
    V, ramp = 1.0, 3.0e-6
    raw = bar(4.0e-5)
    raw["model"]["prescribed"] = [{"group": "left", "dofs": ["ux"], "quantity": "velocity",
                                   "kind": "tabulated", "table": [[0, 0], [ramp, V], [1, V]]}]
    raw["probes"] = [{"name": "B", "at": [0.16, 0.0012]}]
    res = run(raw)
    vel, sig = plateau(res.probes["B"], 0.16 / C + 2 * ramp)
    en = res.energy
    work = float(en["external_work"][-1])
    exact_work = RHO * C * V ** 2 * H * THICK * (float(en["t"][-1]) - 2 * ramp / 3)
    balance = float(np.abs(en["total"] - en["total"][0] - en["external_work"]).max()) / work
    return [("driven bar (V = 1 m/s ramped over 3 us), 160 mm: particle velocity (V)", vel, V),
            ("driven bar, 160 mm: stress (-rho c V)", sig, -RHO * C * V),
            ("driven bar: the support's work at 40 us", work, exact_work)], balance


def hanging():
    g = 1000.0
    raw = bar(1.0, gravity=[-g, 0], analysis="static")
    raw["time"] = {"end": 1.0, "dt": 1.0}
    del raw["partitions"]
    raw["model"]["fixed"] = ["right"]
    raw["probes"] = [{"name": "tip", "at": [0.0, 0.0012]}, {"name": "mid", "at": [0.16, 0.0012]}]
    res = run(raw)
    return [("hanging bar (g = 1000 m/s^2), static: free end displacement (-rho g L^2/2E)",
             float(res.probes["tip"]["displacement"][0]), -RHO * g * L ** 2 / (2 * E)),
            ("hanging bar: stress 160 mm below the free end, rho g h",
             float(res.probes["mid"]["stress"][0]), RHO * g * 0.16)]


EC, LC, HC, Q = 1e9, 0.1, 0.01, 1e3


def cantilever(integration, nu=0.4999, dt=None):
    raw = {"name": "cantilever", "time": {"end": 1.0},
           "model": {"kind": "continuum", "mesh": str(ROOT / "meshes" / "cantilever.geo"),
                     "mesh_parameters": {"nx": 40, "ny": 4},
                     "material": {"E": EC, "nu": nu, "rho": 1000.0, "kind": "plane_strain"},
                     "body": "solid", "fixed": ["left"], "integration": integration},
           "loads": [{"group": "right", "kind": "rectangular", "amplitude": Q, "duration": 2.0,
                      "direction": [0, 1]}],
           "probes": [{"name": "tip", "at": [LC, HC / 2], "component": 1}]}
    if dt is None:
        raw["analysis"] = "static"
    else:
        raw["time"] = {"end": 10 * dt, "dt": dt}
        raw["partitions"] = [{"name": "fem", "method": "fem", "group": "solid",
                              "integrator": "explicit", "ratio": 1}]
    return raw


def timoshenko(nu):
    P, inertia, G = Q * HC, HC ** 3 / 12, EC / (2 * (1 + nu))
    return P * LC ** 3 / (3 * EC / (1 - nu ** 2) * inertia) + P * LC / (5 / 6 * G * HC)


def incompressible():
    rows, steps = [], []
    for integration in ("full", "selective", "reduced"):
        res = run(cantilever(integration))
        rows.append((f"cantilever nu = 0.4999, 40 x 4 quad4, {integration}: tip deflection",
                     float(res.probes["tip"]["displacement"][0]), timoshenko(0.4999)))
        crit = run(cantilever(integration, dt=1e-9)).partitions["fem"]["critical_step"]
        verdict = []
        for factor in (1.01, 0.99):
            try:
                run(cantilever(integration, dt=factor * crit))
                verdict.append("ran")
            except SceneError:
                verdict.append("refused")
        steps.append((integration, crit, verdict))
    return rows, steps


def main():
    start = time.perf_counter()
    cases = struck()
    more, balance = driven()
    cases += more + hanging()
    rows, steps = incompressible()
    cases += rows
    lines = ["| case | computed | exact or reference | ratio |", "|---|---|---|---|"]
    for label, got, ref in cases:
        lines.append(f"| {label} | {got:.5g} | {ref:.5g} | {got / ref:.4f} |")
    lines += ["", f"Driven bar: kinetic + strain - work - initial energy stays within "
              f"{balance:.1e} of the work over the run.", "",
              "Stable steps of the cantilever (explicit, nu = 0.4999), as the guard applies "
              "them before stepping:", "",
              "| integration | critical step | at 1.01 x | at 0.99 x |", "|---|---|---|---|"]
    for integration, crit, (above, below) in steps:
        lines.append(f"| {integration} | {crit:.4g} s | {above} | {below} |")
    lines += ["", f"{time.perf_counter() - start:.1f} s for all runs."]
    write("bench_continua", lines)


if __name__ == "__main__":
    main()
