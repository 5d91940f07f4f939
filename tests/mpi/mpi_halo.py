"""Run under ``mpiexec -n N python -m pytest tests/mpi/mpi_halo.py`` (N = 2, 4;
tests/test_contact_halo.py does).

Contact through a halo (solver/partitions/halo.py): the lattice bar of
tests/test_contact_halo.py, one dem partition split over all N ranks, whose
particles touch three spacings apart (so every contact across a cut reaches
beyond the pieces' bond ghosts), against the same bar on one rank (each
process alone, COMM_SELF).
"""
import numpy as np
import pytest
from mpi4py import MPI

from test_contact_halo import SAMPLES, halo_bar, stepped

WORLD = MPI.COMM_WORLD


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """(the bar on this process alone, the bar on all ranks)."""
    tmp = WORLD.bcast(tmp_path_factory.mktemp("halo") if WORLD.rank == 0 else None)
    return (stepped(halo_bar(tmp, f"serial_{WORLD.rank}"), MPI.COMM_SELF),
            stepped(halo_bar(tmp, "parallel"), WORLD))


def test_the_halo_finds_every_contact_of_one_rank(runs):
    """At every sample the pieces' contact pairs, each counted by one piece,
    are the 1-rank pairs (no pair twice, none missing); the displacements
    agree to 1e-12 of their largest; the halo changed between builds and no
    piece saw every particle."""
    serial, parallel = runs
    for k in range(len(SAMPLES)):
        pieces = WORLD.allgather(parallel["pairs"][k])
        pairs = np.concatenate(pieces)
        assert len(pairs) == len(serial["pairs"][k]) > 100, k       # each pair once
        assert set(map(tuple, pairs.tolist())) == set(map(tuple, serial["pairs"][k].tolist()))
        u1, un = merged([serial["u"][k]]), merged(WORLD.allgather(parallel["u"][k]))
        assert np.abs(u1 - un).max() <= 1e-12 * np.abs(u1).max(), k
    builds = parallel["builds"]
    assert builds == serial["builds"] > 2          # the same rebuilds: one decision for all
    sizes = WORLD.allgather(parallel["halo_sizes"])
    assert all(min(s) > 0 for s in sizes)
    assert any(min(s) < max(s) for s in sizes)      # the halo followed the particles
    seen = WORLD.allgather(parallel["seen"])
    assert max(seen) < serial["seen"]               # no piece sees every particle
    WORLD.barrier()


@pytest.fixture(scope="module")
def history_runs(tmp_path_factory):
    """The bar with friction 0.02 on shear springs (friction_model history)."""
    tmp = WORLD.bcast(tmp_path_factory.mktemp("history") if WORLD.rank == 0 else None)
    return (stepped(halo_bar(tmp, f"hs_{WORLD.rank}", "history"), MPI.COMM_SELF),
            stepped(halo_bar(tmp, "hp", "history"), WORLD))


def test_shear_histories_cross_the_cuts_and_the_halo_rebuilds(history_runs):
    """With shear springs kept per pair: at every sample the pieces' histories
    (each pair counted once) are the 1-rank histories (the same pairs, their
    shear displacements to 1e-12 of the largest) and the displacements agree
    to 1e-12 of their largest; contacts slid, and the work of sliding summed
    over the pieces (each pair's shared half per owned end) is the 1-rank
    work."""
    serial, parallel = history_runs
    for k in range(len(SAMPLES)):
        rows = np.concatenate(WORLD.allgather(parallel["shear"][k]))
        one = serial["shear"][k]
        assert len(rows) == len(one) > 50, k
        rows = rows[np.lexsort((rows[:, 1], rows[:, 0]))]
        assert np.array_equal(rows[:, :2], one[:, :2])
        xi = np.abs(one[:, 2:4]).max()
        assert xi > 0 and np.abs(rows[:, 2:] - one[:, 2:]).max() <= 1e-12 * np.abs(one[:, 2:]).max()
        u1, un = merged([serial["u"][k]]), merged(WORLD.allgather(parallel["u"][k]))
        assert np.abs(u1 - un).max() <= 1e-12 * np.abs(u1).max(), k
    assert parallel["builds"] == serial["builds"] > 2
    slid = WORLD.allreduce(parallel["slid"])
    assert serial["slid"] > 0 and abs(slid - serial["slid"]) <= 1e-9 * serial["slid"]
    WORLD.barrier()


def test_ranks_other_than_0_have_contacts_beyond_their_share(runs):
    """The old bug: a piece on rank r > 0 holds only its share of the model's
    bonds (those of its particles), and contact once gathered just the
    particles of those bonds; its contacts reach particles outside them,
    which the halo brings (the pairs above are complete)."""
    beyond = runs[1]["beyond_share"] if WORLD.rank > 0 else 0
    assert sum(WORLD.allgather(beyond)) > 0
    WORLD.barrier()


def merged(chunks):
    """{global id: row} chunks of the owned displacements into one array by id."""
    rows = {}
    for chunk in chunks:
        rows.update(chunk)
    return np.array([rows[g] for g in sorted(rows)])
