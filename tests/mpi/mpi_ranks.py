"""Run under ``mpiexec -n 2 python -m pytest tests/mpi/mpi_ranks.py``.

The same scene on one rank (each process alone, COMM_SELF) and on two ranks
(COMM_WORLD, one partition per rank) must give the same histories.
"""
import numpy as np
import pytest
from mpi4py import MPI

from conftest import raw_scene, run_scene


@pytest.fixture
def shared_tmp(tmp_path_factory):
    path = tmp_path_factory.mktemp("mpi") if MPI.COMM_WORLD.rank == 0 else None
    return MPI.COMM_WORLD.bcast(path)


@pytest.mark.parametrize("treatment,eta", [("taylor", 5), ("layers", 5), ("literal", 20)])
def test_one_and_two_ranks_agree(treatment, eta, shared_tmp):
    world = MPI.COMM_WORLD
    assert world.size == 2
    raw = raw_scene("six_dof")
    raw["time"]["end"] = 4.0
    raw["partitions"][0]["ratio"] = eta
    raw["coupling"]["external"] = treatment
    raw["name"] = f"serial_{world.rank}"
    serial = run_scene(raw, shared_tmp, comm=MPI.COMM_SELF)
    raw["name"] = "parallel"
    parallel = run_scene(raw, shared_tmp, comm=world)
    assert parallel.attrs["ranks"] == 2 and serial.attrs["ranks"] == 1
    a, b = serial.probes["x3"], parallel.probes["x3"]
    scale = np.abs(a["displacement"]).max()
    assert np.abs(a["displacement"] - b["displacement"]).max() <= 1e-12 * scale
    assert np.abs(a["velocity"] - b["velocity"]).max() <= 1e-12 * np.abs(a["velocity"]).max()
    assert np.allclose(serial.energy["total"], parallel.energy["total"], rtol=1e-12, atol=0)
    assert parallel.partitions["fem"]["steps"] == serial.partitions["fem"]["steps"]
    world.barrier()


def test_staggered_one_and_two_ranks_agree(shared_tmp):
    world = MPI.COMM_WORLD
    raw = raw_scene("metamaterial_implicit")
    raw["time"]["end"] = 0.01
    raw["reference"] = "none"
    raw["probes"] = [{"name": "p550", "node": 305}]     # DEM side, reached within 10 ms
    raw["name"] = f"stag_serial_{world.rank}"
    serial = run_scene(raw, shared_tmp, comm=MPI.COMM_SELF)
    raw["name"] = "stag_parallel"
    parallel = run_scene(raw, shared_tmp, comm=world)
    a, b = serial.probes["p550"], parallel.probes["p550"]
    assert np.abs(a["displacement"]).max() > 0
    assert np.abs(a["displacement"] - b["displacement"]).max() <= 1e-12 * np.abs(a["displacement"]).max()
    world.barrier()


def test_mesh_is_read_on_one_rank_and_broadcast():
    from solver.mesh import read
    world = MPI.COMM_WORLD
    mesh = read("meshes/bar2d.geo", world)
    points = world.allgather(mesh.points)
    assert points[0].shape == (164, 2) and np.array_equal(points[0], points[1])
    assert sorted(mesh.groups) == ["left", "right", "solid"]


def test_continuum_one_and_two_ranks_agree(shared_tmp):
    from test_continuum import split_bar
    world = MPI.COMM_WORLD
    raw = split_bar(shared_tmp, eta=2, end=4e-6)
    raw["name"] = f"cont_serial_{world.rank}"
    serial = run_scene(raw, shared_tmp, comm=MPI.COMM_SELF)
    raw["name"] = "cont_parallel"
    parallel = run_scene(raw, shared_tmp, comm=world)
    for probe in ("mid", "w"):
        a, b = serial.probes[probe]["velocity"], parallel.probes[probe]["velocity"]
        assert np.abs(a).max() > 0
        assert np.abs(a - b).max() <= 1e-12 * np.abs(a).max()
    world.barrier()
