"""Cook's membrane (configs/cook_membrane.yaml, meshes/cook.geo): the
vertical displacement of the corner C = (48, 60) as the mesh is refined, for
triangles (tri3), quadrilaterals with full, selective and reduced (one
point, hourglass 0.1) integration (model.integration), at nu = 1/3 and near incompressible
(nu = 0.4999), plane strain, statically.

    python benchmarks/bench_cook.py [--levels 4,8,16,32,64]

References: nu = 1/3, very fine quadratic meshes of CalculiX, Code_Aster and
Elmer give 32.27, 32.20 and 32.28 (the CoFEA comparison, as quoted by the
solids4foam tutorial "cooksMembrane"): 32.25 is used.  nu = 0.4999 has no
published value in this setting: the reference is the selective quads'
Aitken extrapolation from the three finest meshes (their order of convergence
taken from the data: about 1.3, the corner's singularity), marked so.
Writes docs/benchmarks/bench_cook.md.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))
import solver  # noqa: E402  (first: one BLAS thread, as in the solver)

from tables import write  # noqa: E402

PUBLISHED = 32.25
ELEMENTS = (("tri3", 0, "full"), ("quad4 full", 1, "full"), ("quad4 selective", 1, "selective"),
            ("quad4 reduced", 1, "reduced"))


def corner(n, quads, integration, nu, out):
    """The displacement of C from one static run of configs/cook_membrane.yaml."""
    from mpi4py import MPI
    scene = solver.load(ROOT / "configs" / "cook_membrane.yaml",
                        [f"model.mesh_parameters.n={n}", f"model.mesh_parameters.quads={quads}",
                         f"model.integration={integration}", f"model.material.nu={nu}",
                         f"output.file={out}"])
    result = solver.run(scene, comm=MPI.COMM_SELF, log=lambda *a, **k: None, overwrite=True)
    return float(result.probes["C"]["displacement"][0])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--levels", default="4,8,16,32,64")
    args = ap.parse_args()
    levels = [int(x) for x in args.levels.split(",")]
    import tempfile
    start = time.perf_counter()
    values = {}
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "cook.h5"
        for nu in (1 / 3, 0.4999):
            for label, quads, integration in ELEMENTS:
                values[nu, label] = [corner(n, quads, integration, nu, out) for n in levels]
    a, b, c = values[0.4999, "quad4 selective"][-3:]
    extrapolated = c - (c - b) ** 2 / ((c - b) - (b - a))       # Aitken: the order from the data
    lines = [f"Vertical displacement of C / the reference, {levels[0]} to {levels[-1]} cells per "
             f"side (triangles: each quad split in two). nu = 1/3: reference {PUBLISHED} "
             "(CalculiX 32.27, Code_Aster 32.20, Elmer 32.28 on very fine quadratic meshes); "
             f"nu = 0.4999: {extrapolated:.3f}, the selective quads' Aitken extrapolation from "
             f"the three finest meshes (no published value in this setting).", "",
             "| nu | element | " + " | ".join(f"{n} x {n}" for n in levels) + " |",
             "|---|---|" + "---|" * len(levels)]
    for nu, ref in ((1 / 3, PUBLISHED), (0.4999, extrapolated)):
        for label, _, _ in ELEMENTS:
            lines.append(f"| {'1/3' if nu < 0.4 else '0.4999'} | {label} | " +
                         " | ".join(f"{v / ref:.3f}" for v in values[nu, label]) + " |")
    lines += ["", f"Displacements at {levels[-1]} x {levels[-1]}: " + ", ".join(
        f"{label} {values[nu, label][-1]:.3f} (nu {'1/3' if nu < 0.4 else '0.4999'})"
        for nu in (1 / 3, 0.4999) for label, _, _ in ELEMENTS)
        + f"; {time.perf_counter() - start:.1f} s for all runs."]
    write("bench_cook", lines, doc=args.levels == "4,8,16,32,64")


if __name__ == "__main__":
    main()
