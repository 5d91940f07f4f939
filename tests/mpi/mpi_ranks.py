"""Run under ``mpiexec -n N python -m pytest tests/mpi/mpi_ranks.py`` (N = 2, 4, ...).

The same scene on one rank (each process alone, COMM_SELF) and on all N ranks
(COMM_WORLD: partitions split over several ranks, or sharing ranks) must give
the same histories: explicit partitions to 1e-12 relative, implicit ones
(CG + GAMG across ranks instead of LU) to 1e-8.
"""
import os

import numpy as np
import pytest
from mpi4py import MPI

from conftest import raw_scene, run_scene

WORLD = MPI.COMM_WORLD
# more ranks than cores: every message waits for a time slice (~5 ms), so keep runs short
OVERSUBSCRIBED = WORLD.size > (len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
                               else os.cpu_count())


@pytest.fixture
def shared_tmp(tmp_path_factory):
    path = tmp_path_factory.mktemp("mpi") if WORLD.rank == 0 else None
    return WORLD.bcast(path)


def both(raw, tmp, name):
    """(1-rank result, N-rank result) of ``raw``."""
    raw = dict(raw)
    raw["name"] = f"{name}_serial_{WORLD.rank}"
    serial = run_scene(raw, tmp, comm=MPI.COMM_SELF)
    raw["name"] = f"{name}_parallel"
    parallel = run_scene(raw, tmp, comm=WORLD)
    assert serial.attrs["ranks"] == 1 and parallel.attrs["ranks"] == WORLD.size
    return serial, parallel


def rel(a, b) -> float:
    scale = np.abs(a).max()
    assert scale > 0
    return float(np.abs(a - b).max() / scale)


@pytest.mark.parametrize("treatment,eta", [("taylor", 5), ("layers", 5), ("literal", 20)])
def test_network_any_rank_count(treatment, eta, shared_tmp):
    raw = raw_scene("six_dof")
    raw["time"]["end"] = 0.07 if OVERSUBSCRIBED else 4.0      # x3 moves from 0.01 s
    raw["partitions"][0]["ratio"] = eta
    raw["coupling"]["external"] = treatment
    serial, parallel = both(raw, shared_tmp, f"net_{treatment}")
    a, b = serial.probes["x3"], parallel.probes["x3"]
    assert rel(a["displacement"], b["displacement"]) <= 1e-12
    assert rel(a["velocity"], b["velocity"]) <= 1e-12
    assert np.allclose(serial.energy["total"], parallel.energy["total"], rtol=1e-12, atol=0)
    assert parallel.partitions["fem"]["steps"] == serial.partitions["fem"]["steps"]
    # every rank serves a partition: with 4 ranks each 3-node partition is split in two
    assert sum(p["ranks"] for p in parallel.partitions.values()) == max(WORLD.size, 2)
    WORLD.barrier()


def test_staggered_implicit_on_several_ranks(shared_tmp):
    raw = raw_scene("metamaterial_implicit")
    raw["time"]["end"] = 0.0005 if OVERSUBSCRIBED else 0.01
    raw["reference"] = "none"
    probes = ["p10"] if OVERSUBSCRIBED else ["p10", "p550"]       # where the wave has come
    raw["probes"] = [{"name": "p550", "node": 305}, {"name": "p10", "node": 10}]
    serial, parallel = both(raw, shared_tmp, "stag")
    implicit_ranks = parallel.partitions["fem"]["ranks"]
    tol = 1e-8 if implicit_ranks > 1 else 1e-12      # CG + GAMG vs LU
    for probe in probes:
        assert rel(serial.probes[probe]["displacement"],
                   parallel.probes[probe]["displacement"]) <= tol, probe
    WORLD.barrier()


def test_continuum_split_over_ranks(shared_tmp):
    from test_continuum import split_bar
    raw = split_bar(shared_tmp, eta=2, end=4e-6)
    serial, parallel = both(raw, shared_tmp, "cont")
    for probe in ("mid", "w"):
        assert rel(serial.probes[probe]["velocity"], parallel.probes[probe]["velocity"]) <= 1e-12
    WORLD.barrier()


def test_single_partition_split_over_all_ranks(shared_tmp):
    raw = raw_scene("wave_bar_fem")
    raw["time"] = {"end": 1e-6 if OVERSUBSCRIBED else 2e-6, "dt": 2e-8}   # A moves from 0.3 us
    raw["reference"] = "none"
    raw["probes"] = [{"name": "A", "at": [0.002, 0.0012]}]
    serial, parallel = both(raw, shared_tmp, "single")
    assert parallel.partitions["fem"]["ranks"] == WORLD.size
    assert rel(serial.probes["A"]["velocity"], parallel.probes["A"]["velocity"]) <= 1e-12
    WORLD.barrier()


def test_coupled_3d_lattice_split_over_ranks(shared_tmp):
    raw = raw_scene("bar3d")
    raw["time"]["end"] = 2.4e-6
    serial, parallel = both(raw, shared_tmp, "bar3d")
    assert rel(serial.probes["D"]["velocity"], parallel.probes["D"]["velocity"]) <= 1e-12
    # rank 0 let go of the whole model (no fields): its counts were taken before
    assert parallel.attrs["fe_cells"] == serial.attrs["fe_cells"] > 0
    WORLD.barrier()


def test_mesh_is_read_on_one_rank_and_broadcast():
    from solver.model.mesh import read
    mesh = read("meshes/bar2d.geo", WORLD)
    points = WORLD.allgather(mesh.points)
    assert points[0].shape == (164, 2) and all(np.array_equal(points[0], p) for p in points)
    assert sorted(mesh.groups) == ["left", "right", "solid"]


def test_mixed_dof_counts_split_over_ranks():
    """Nodes with 1 and 2 DOFs (tests/mixed_dofs.py): scalar MPIAIJ operators,
    pieces and the exchange over all ranks give the 1-rank histories."""
    from mixed_dofs import mixed, run
    from solver.model import arrays
    from solver.model.binding import from_dict
    raw = raw_scene("six_dof")
    raw["time"]["end"] = 0.05 if OVERSUBSCRIBED else 1.0
    scene = from_dict(raw)
    model = mixed(arrays.build(scene))
    n = scene.n_system_steps
    serial = run(scene, model, MPI.COMM_SELF, n)
    parallel = run(scene, model, WORLD, n)
    assert sorted(serial) == sorted(parallel) and len(serial) == 9
    for key in serial:
        a, b = serial[key], parallel[key]
        assert np.abs(a - b).max() <= 1e-12 * max(np.abs(a).max(), 1e-30), key
    WORLD.barrier()


def test_rank0_reads_the_mesh_and_sends_each_rank_its_cells(shared_tmp):
    """The command line's path: rank 0 loads and binds the scene (the mesh is
    read on rank 0 only); every rank, rank 0 too once it has shared the model
    out (no fields), holds the cells that touch its nodes, never the whole
    mesh, and only its slice of the plan: its own piece and the numbering of
    the nodes near it, no layout or numbering of every node."""
    from solver.partitions.distribute import Numbering
    from solver.driver.build import build
    from solver.model import data as model_data
    from solver.tools.cli import load_on_root
    from conftest import write_scene
    raw = raw_scene("wave_bar_fem")
    raw["name"] = "share"
    path = shared_tmp / "share.yaml"
    if WORLD.rank == 0:
        write_scene(path, raw)
    WORLD.barrier()
    store = model_data.ModelData()
    scene, _ = load_on_root(WORLD, path, [], store)
    assert (len(store) == 1) == (WORLD.rank == 0)
    asm = build(scene, WORLD)
    counts = WORLD.allgather(sum(len(conn) for _, conn, _ in asm.model.cells))
    held = np.concatenate([p.layout.held for p in asm.parts])
    inh = np.zeros(asm.model.n_nodes, bool)
    inh[held] = True
    whole = WORLD.bcast(sum(len(c) for c in scene_cells(scene)) if WORLD.rank == 0 else None)
    ok = (all(inh[conn].any(axis=1).all() for _, conn, _ in asm.model.cells)   # touching only
          and counts[WORLD.rank] < whole and sum(counts) >= whole)
    ok = ok and all(p.dist.layout is None and isinstance(p.dist.number, Numbering)
                    and p.dist.number.nodes.size < asm.model.n_nodes
                    and sum(q is not None for q in p.dist.pieces) == 1 for p in asm.parts)
    asm.destroy()
    assert all(WORLD.allgather(ok)), counts         # (every rank fails together: no hang)
    WORLD.barrier()


def scene_cells(scene):
    from solver.model import data as model_data
    mesh = model_data.read(scene.model)
    return list(mesh.group(scene.model.body).cells.values())


def test_errors_found_on_rank0_stop_every_rank(shared_tmp):
    from solver.errors import LaunchError, SceneError
    from solver.driver.build import build
    from solver.model.binding import from_dict
    from solver.tools.cli import load_on_root
    from conftest import write_scene
    raw = raw_scene("wave_bar_fem")
    raw["model"]["fixed"] = ["nowhere"]
    path = shared_tmp / "bad.yaml"
    if WORLD.rank == 0:
        write_scene(path, raw)
    WORLD.barrier()
    with pytest.raises(SceneError, match="model.fixed: mesh has no physical group 'nowhere'"):
        load_on_root(WORLD, path, [])
    raw = raw_scene("six_dof")
    raw["partitions"][0]["ranks"] = WORLD.size + 1        # planned on rank 0: more than the run has
    with pytest.raises(LaunchError, match="ranks"):
        build(from_dict(raw), WORLD)
    WORLD.barrier()


def test_ranks_waiting_for_rank0_wait_asleep():
    """collective.on_root and agree: while rank 0 works alone (here: 1 s) the
    other ranks wait asleep (collective.idle), not in MPI's busy poll, which
    took CPU time from rank 0's model build on this 2-core machine."""
    import time
    from solver.collective import agree, on_root
    t0 = time.process_time()
    on_root(WORLD, time.sleep, 1.0)
    if WORLD.rank == 0:
        time.sleep(1.0)
    agree(WORLD, None)
    cpu = time.process_time() - t0
    assert all(WORLD.allgather(WORLD.rank == 0 or cpu < 0.5)), cpu
    WORLD.barrier()
