"""Contact on a dem partition split over ranks, through a halo of the
particles near each piece (solver/partitions/halo.py; issue 23).

The scene: a lattice bar (meshes/bar2d.geo, 41 x 4 particles of spacing a =
0.8 mm) that is one dem partition, with particles of radius 1.55 a: two that
share no bond touch up to 3.1 a apart, so a piece's contacts across a cut
reach particles three spacings away, beyond its bond ghosts (the other
pieces' ends of its own bonds).  The skin, 0.07 a, puts 2r + skin = 3.17 a
just beyond the lattice distance sqrt(10) a = 3.162 a, so a strong
compression-then-tension pulse moves particles in and out of the halos, and
its displacements (a few skins) rebuild the search several times.
"""
from __future__ import annotations

import numpy as np
import pytest

from conftest import ROOT, mpi_pytest

A = 8.0e-4
SAMPLES = (60, 120, 180, 240)          # system steps at which pairs and displacements are taken


def halo_bar(tmp, name: str, friction: str | None = None) -> dict:
    """The bar; ``friction``: its contacts' friction_model (friction 0.02; None:
    frictionless)."""
    pulse = {"group": "left", "kind": "half_sine", "amplitude": 1.5e5, "duration": 2.0e-6}
    raw = {
        "name": f"halo_{name}", "time": {"end": SAMPLES[-1] * 4.0e-8, "dt": 4.0e-8},
        "model": {
            "kind": "continuum", "mesh": str(ROOT / "meshes" / "bar2d.geo"),
            "material": {"E": 70.0e9, "nu": 0.33, "rho": 2700.0, "kind": "plane_stress",
                         "thickness": 3.2e-4},
            "body": "solid",
            "lattice": {"region": "solid", "spacing": A, "geometry": "nonlinear",
                        "contact": {"stiffness": 1.68e4, "radius": 1.55 * A,
                                    "skin": 0.07 * A}}},
        "partitions": [{"name": "dem", "method": "dem", "group": "solid", "integrator": "verlet",
                        "ratio": 1}],
        "loads": [dict(pulse, direction=[1.0, 0.0]),
                  dict(pulse, start=3.0e-6, direction=[-1.0, 0.0])],
        "reference": "none",
        "output": {"file": str(tmp / f"{name}.h5"), "progress": 0},
    }
    if friction is not None:
        raw["model"]["lattice"]["contact"].update(friction=0.02, friction_model=friction)
    return raw


def stepped(raw, comm) -> dict:
    """``raw`` stepped on ``comm`` to each of SAMPLES: this piece's contact
    pairs (global ids, those it counts), owned displacements ({id: u}) and
    the largest rest distance of its touching pairs [a] at each, its search
    builds and halo sizes, the particles it sees, and its contacts with a
    particle outside its share of the model's bonds."""
    from solver import scene as scene_mod
    from solver.driver.build import build
    from solver.model import binding
    from solver.model.continuum import BondStiffness
    asm = build(binding.bind(scene_mod.from_dict(raw)), comm)
    dem = asm.parts[0]
    force, Dt = dem.force, asm.scene.system_dt
    shared = np.unique(np.concatenate([c for c, k in dem.force_model.bond_blocks(
        dem.whole_held()) if isinstance(k, BondStiffness)]))
    out = {"pairs": [], "u": [], "apart": [], "beyond_share": 0, "shear": [],
           "slid": 0.0}
    s = 0
    for stop in SAMPLES:
        while s < stop:
            asm.scheme.step(s * Dt)
            s += 1
            out["slid"] += force.contact._slipped         # the work of sliding (this piece's)
        out["pairs"].append(force.contact_pairs())
        out["shear"].append(force.contact_history())      # (a, b, xi, separation) or None
        U = dem.U[:dem.n_own].reshape(-1, 2).copy()
        out["u"].append(dict(zip(dem.layout.owned.tolist(), U)))
        i, j = force.contact.touching()
        ends = np.concatenate([force.ids[i], force.ids[j]])
        out["beyond_share"] += int(np.sum(~np.isin(ends, shared)))
        out["apart"].append(np.linalg.norm(force.X[j] - force.X[i], axis=1).max(initial=0) / A)
    out.update(builds=force.contact.builds, seen=int(force.ids.size),
               halo_sizes=list(force.halo.sizes) if force.halo is not None else [])
    asm.destroy()
    return out


def test_on_one_rank_there_is_no_halo_and_the_pairs_reach_three_spacings(tmp_path):
    """1 rank: every particle is held, no halo; the contacts include pairs
    three spacings apart (not bond neighbours), and the search is rebuilt."""
    from mpi4py import MPI
    one = stepped(halo_bar(tmp_path, "one"), MPI.COMM_SELF)
    assert one["halo_sizes"] == [] and one["seen"] == 41 * 4
    assert one["builds"] > 2
    for pairs, apart in zip(one["pairs"], one["apart"]):
        assert len(pairs) > 100 and abs(apart - 3.0) < 1e-9      # rest distances up to 3 a


@pytest.mark.parametrize("n", [2, 4])
def test_contact_through_the_halo_on_n_ranks(n, tmp_path):
    """tests/mpi/mpi_halo.py under mpiexec -n N (4 oversubscribes this machine):
    every test passes on every rank."""
    for rank, counts in enumerate(mpi_pytest("tests/mpi/mpi_halo.py", n, tmp_path)):
        assert counts == {"tests": 3, "failures": 0, "errors": 0, "skipped": 0}, (rank, counts)
