"""Rank assignment: by estimated cost, as the scene says, or shared when short."""
import re

import pytest

from solver.errors import LaunchError
from solver.partitions.ranks import assign


def test_one_rank_each_and_the_rest_by_cost():
    a = assign(8, [300.0, 100.0], [1000, 1000], [None, None])
    assert [len(r) for r in a.ranks] == [6, 2]
    assert a.ranks == (tuple(range(6)), (6, 7))          # disjoint and contiguous
    assert a.partitions_on(5) == [0] and a.partitions_on(6) == [1]


def test_a_partition_never_gets_more_ranks_than_nodes():
    a = assign(6, [1000.0, 1.0], [2, 100], [None, None])
    assert [len(r) for r in a.ranks] == [2, 4]
    a = assign(6, [1.0, 1.0], [2, 2], [None, None])      # only 4 useful ranks
    assert [len(r) for r in a.ranks] == [2, 2] and "2 rank(s) idle" in a.how


def test_fewer_ranks_than_partitions_share_by_cost():
    a = assign(2, [5.0, 4.0, 3.0, 2.0], [9] * 4, [None] * 4)
    assert all(len(r) == 1 for r in a.ranks)
    assert a.partitions_on(0) == [0, 3] and a.partitions_on(1) == [1, 2]   # loads 7 and 7


def test_ranks_from_the_scene():
    a = assign(5, [1.0, 100.0, 1.0], [50] * 3, [3, None, None])
    assert [len(r) for r in a.ranks] == [3, 1, 1]
    a = assign(4, [1.0, 1.0], [50, 50], [1, 3])
    assert a.ranks == ((0,), (1, 2, 3))


@pytest.mark.parametrize("size,requested,words", [
    (4, [1, 2], "add up to 3 (partitions[0].ranks = 1, partitions[1].ranks = 2) but 4 ranks"),
    (2, [2, None], "3 in all (this scheme keeps its sides on ranks of their own), but 2 were "
                   "launched; run with -n 3"),
    (2, [3, None], "ask for 3 ranks (partitions[0].ranks = 3), but 2 were launched; run with -n 3"),
    (100, [60, None], "partitions[0].ranks: 60 ranks for 50 owned nodes"),
])
def test_ranks_that_do_not_fit_are_refused(size, requested, words):
    with pytest.raises(LaunchError, match=re.escape(words)):
        assign(size, [1.0, 1.0], [50, 50], requested, ride=False)


def test_a_partition_left_without_a_rank_rides():
    """partitions[].ranks take every rank: the others ride, most expensive on
    the least loaded rank first; with a rank or more left, the most expensive
    take them and only the cheapest ride."""
    a = assign(2, [1.0, 10.0], [50, 50], [None, 2])
    assert a.ranks == ((0,), (0, 1)) and "partition 0 runs on rank 0" in a.how
    a = assign(3, [1.0, 4.0, 9.0, 2.0], [50] * 4, [None, None, 2, None])   # loads 4, 4.5, 4.5
    assert a.ranks == ((1,), (0,), (1, 2), (0,))      # then 3 joins rank 0 and 0 rank 1
    assert "partition 0 runs on rank 1" in a.how and "partition 3 runs on rank 0" in a.how


def test_a_cheap_partition_rides_on_a_rank_of_another():
    """2 ranks, costs 3 % and 97 %: a rank each leaves the slowest rank 97; the
    expensive partition on both ranks and the cheap one beside it on the less
    loaded, 48.5 + 3 (0.53 x).  Where riding gains under 10 %, or would cut a
    partition into pieces of fewer than 1,000 owned nodes, the ranks stay
    disjoint."""
    a = assign(2, [3.0, 97.0], [100, 4000], [None, None])
    assert a.ranks == ((0,), (0, 1)) and "partition 0 (3 % of the cost) runs on rank 0" in a.how
    assert a.partitions_on(0) == [0, 1] and a.partitions_on(1) == [1]
    a = assign(4, [10.0, 10.0, 1.0], [5000] * 3, [None] * 3)       # 10 -> 5 + 1
    assert a.ranks == ((0, 1), (2, 3), (0,))
    assert assign(2, [45.0, 55.0], [5000, 5000], [None, None]).ranks == ((0,), (1,))
    assert assign(3, [10.0, 18.0], [5000] * 2, [None, None]).ranks == ((0,), (1, 2))  # 10 vs 9.3
    for nodes in (1, 1999):      # too few owned nodes for two pieces of 1,000
        assert assign(2, [3.0, 97.0], [100, nodes], [None, None]).ranks == ((0,), (1,))


def test_rank0_lets_go_of_the_whole_model_only_where_nothing_reads_it():
    """On several ranks rank 0 keeps only its share of a continuum model,
    unless fields or a measured balance read it whole (modal references are
    for networks, which keep theirs)."""
    from conftest import raw_scene
    from solver.partitions.partitioning import lets_go
    from solver.scene.file import from_dict
    raw = raw_scene("bar3d")
    assert lets_go(from_dict(raw), 2) and not lets_go(from_dict(raw), 1)
    assert lets_go(from_dict({**raw, "output": None}), 2)          # no output section at all
    for key, value in (("output", {"file": "x.h5", "fields": {"every": 10}}),
                       ("balance", "measured")):
        assert not lets_go(from_dict({**raw, key: value}), 2), key
    assert not lets_go(from_dict(raw_scene("six_dof")), 2)          # a network
