"""Run under ``mpiexec -n 3 python -m pytest tests/mpi/mpi_balance.py``
(tests/test_ranks_measured.py does).

``balance: measured`` with the clock's walls replaced by constructed ones
(after the real timed steps, so the scheme has stepped): a partition split
over two ranks gives one up and is rebuilt, or keeps them and its initial
state is put back.  The histories equal, bitwise, an estimated run on the same
ranks, and the estimated run on the others to 1e-12.
"""
import copy

import numpy as np
import pytest
from mpi4py import MPI

from solver.driver import balance
from solver.driver.runner import run
from solver.model import binding
from solver.petscutil import init

WORLD = MPI.COMM_WORLD
# p0 (fem, 40 nodes) gets 2 of the 3 ranks by estimated cost (119 against 59 nonzeros)
SCENE = {
    "name": "b", "time": {"end": 0.2, "dt": 1.0e-2},
    "model": {"kind": "network", "generator": {"name": "chain", "n": 60, "mass": 1.0,
                                               "stiffness": 1.0}},
    "partitions": [
        {"name": "p0", "method": "fem", "integrator": "explicit", "ratio": 1,
         "nodes": [{"range": [0, 40]}]},
        {"name": "p1", "method": "dem", "integrator": "verlet", "ratio": 1,
         "nodes": [{"range": [40, 60]}]}],
    "loads": [{"node": 40, "kind": "sine", "amplitude": 1.0, "omega": 3.0}],
    "probes": [{"name": "a", "node": 39}, {"name": "b", "node": 41}],
}


@pytest.fixture
def shared_tmp(tmp_path_factory):
    path = tmp_path_factory.mktemp("balance") if WORLD.rank == 0 else None
    return WORLD.bcast(path)


def scene_run(tmp, name, **changes):
    init([])
    raw = copy.deepcopy(SCENE)
    raw.update(name=name, output={"file": str(tmp / f"{name}.h5"), "progress": 0}, **changes)
    lines = []
    result = run(binding.from_dict(raw), WORLD, log=lines.append)
    return result, "\n".join(lines)


def walls_of(costs):
    """A stand-in for balance.measure: the real timed steps, then ``costs``
    (partition -> s per system step) as every piece's wall."""
    real = balance.measure

    def measure(scheme, steps, Dt, comm):
        real(scheme, steps, Dt, comm)
        local = {part.layout.index: costs[part.layout.index] for part in scheme.parts}
        gathered = comm.gather(local, root=0)
        return (gathered, None) if comm.rank == 0 else (None, None)
    return measure


def histories(result):
    return {f"{p}/{k}": result.probes[p][k] for p in ("a", "b")
            for k in ("displacement", "velocity")} | {"E": result.energy["total"]}


def ranks_of(result):
    return [result.partitions[p]["ranks"] for p in ("p0", "p1")]


def test_rebuilt_on_the_measured_ranks(shared_tmp, monkeypatch):
    """p0 1 ms on each of its 2 ranks, p1 9 ms on 1: costs 2 and 9 ms x ranks,
    so p1 takes the second rank."""
    estimated, _ = scene_run(shared_tmp, "est")
    same, _ = scene_run(shared_tmp, "fixed", partitions=[
        dict(SCENE["partitions"][0], ranks=1), dict(SCENE["partitions"][1], ranks=2)])
    monkeypatch.setattr(balance, "measure", walls_of({0: 1e-3, 1: 9e-3}))
    measured, log = scene_run(shared_tmp, "measured", balance="measured", balance_steps=3)
    assert ranks_of(estimated) == [2, 1] and ranks_of(measured) == ranks_of(same) == [1, 2]
    if WORLD.rank == 0:
        assert "[solver]   before: wait per rank for the slowest 8 / 8 / 0 ms per system " \
               "step (slowest rank 9 ms)" in log, log
        assert "[solver]   after: predicted wait per rank for the slowest 2.5 / 0 / 0 ms per " \
               "system step (slowest rank 4.5 ms)" in log, log
        assert "the assignment changed; the partitions are built again" in log
    assert measured.partitions["p1"]["steps"] == 20
    got, want, other = histories(measured), histories(same), histories(estimated)
    for key in got:
        assert np.array_equal(got[key], want[key]), key
        scale = np.abs(other[key]).max()
        assert scale > 0 and np.abs(got[key] - other[key]).max() <= 1e-12 * scale, key
    WORLD.barrier()


def test_kept_ranks_restore_the_initial_state(shared_tmp, monkeypatch):
    """p0 9 ms on each of its 2 ranks, p1 4 ms: p0 keeps both (p1 riding on
    one of 3 ranks for p0 would load it 6 + 4 ms); the run starts from the
    initial state put back (the scheme stepped 1 + 3 system steps)."""
    estimated, _ = scene_run(shared_tmp, "est_kept")
    monkeypatch.setattr(balance, "measure", walls_of({0: 9e-3, 1: 4e-3}))
    measured, log = scene_run(shared_tmp, "kept", balance="measured", balance_steps=3)
    assert ranks_of(estimated) == ranks_of(measured) == [2, 1]
    if WORLD.rank == 0:
        assert "the assignment is unchanged; the run starts from the initial state put back" \
               in log, log
    assert [measured.partitions[p]["steps"] for p in ("p0", "p1")] == [20, 20]
    got, want = histories(measured), histories(estimated)
    for key in got:
        assert np.array_equal(got[key], want[key]), key
    assert np.array_equal(measured.energy["external_work"], estimated.energy["external_work"])
    WORLD.barrier()
