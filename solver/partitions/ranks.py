"""Which MPI ranks serve which partition.

A partition's cost per system step is estimated as the nonzeros of its owned
rows (stiffness or bond operator) times its steps per system step, or, with
``balance: measured`` (:mod:`solver.driver.balance`), measured: its wall per
system step times its ranks.  With N ranks and P partitions:

* ``partitions[].ranks`` given for every partition: they must add up to N;
  given for some: the others share the remaining ranks by cost, and those
  left without a rank (the cheapest) ride on the least loaded rank, unless
  the scheme keeps its sides on ranks of their own.
* N >= P (default): every partition gets one rank, and the N - P others go
  to the partitions by cost (largest remainder of N * cost share), never more
  ranks than a partition has owned nodes.  Ranks are disjoint and contiguous,
  unless a cheap partition *rides*: it runs on one rank of another
  partition's (the least loaded) while the others share all N ranks, when
  that makes the most loaded rank's cost at least 10 % lower (a fem
  partition of 3 % of the cost beside a dem one on 2 ranks).  Partitions on
  several ranks never share one.
* N < P: every partition runs on one rank; partitions are placed on the
  least-loaded rank, most expensive first, and share ranks.  Partitions on
  one rank advance one after the other.

Each partition with several ranks gets its own sub-communicator (its Mats,
Vecs and KSP live there); a partition on one rank uses COMM_SELF.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from solver.errors import LaunchError


@dataclass(frozen=True)
class Assignment:
    ranks: tuple[tuple[int, ...], ...]     # world ranks of every partition
    costs: tuple[float, ...]               # per system step: nonzeros x steps, or s x ranks
    how: str                               # why, for the log
    basis: str = "estimated"               # estimated (nonzeros x steps) or measured (s x ranks)

    def partitions_on(self, rank: int) -> list[int]:
        return [p for p, rs in enumerate(self.ranks) if rank in rs]

    def lines(self, names) -> list[str]:
        total = sum(self.costs) or 1.0
        out = [f"[solver] ranks: {self.how}"]
        for name, rs, c in zip(names, self.ranks, self.costs):
            amount = (f"measured cost {1e3 * c:.3g} ms x ranks" if self.basis == "measured"
                      else f"cost {c:.3g} nonzeros x steps")
            out.append(f"[solver]   {name}: {span(rs)} ({len(rs)}), {amount} per system step "
                       f"({100 * c / total:.0f}%)")
        return out

    def rank_times(self, walls, size: int) -> np.ndarray:
        """Predicted time per system step of every rank when partition p takes
        ``walls[p]`` on its ranks: the sum over the partitions it serves."""
        return rank_sums(self.ranks, walls, size)


def span(rs) -> str:
    """'rank 3' or 'ranks 1-4' for a contiguous rank tuple."""
    return f"rank {rs[0]}" if len(rs) == 1 else f"ranks {rs[0]}-{rs[-1]}"


def waits(times) -> np.ndarray:
    """Each rank's wait per system step for the slowest: max(times) - times."""
    times = np.asarray(times, dtype=float)
    return times.max(initial=0.0) - times


def measured_cost(wall_per_system_step: float, n_ranks: int) -> float:
    """A partition's measured cost: its wall per system step times its ranks
    (the rank-seconds one system step takes; the assignment divides them)."""
    return float(wall_per_system_step) * n_ranks


def cost(owned_nonzeros: float, steps_per_system_step: int) -> float:
    return float(owned_nonzeros) * steps_per_system_step


def assign(size: int, costs, n_owned, requested, basis: str = "estimated",
           ride: bool = True) -> Assignment:
    """Ranks of every partition for a world of ``size``.

    costs: cost per partition (``basis``: estimated, by :func:`cost`, or
    measured, by :func:`measured_cost`); n_owned: owned nodes per partition
    (cap on its ranks); requested: ``partitions[].ranks`` (None = by cost);
    ``ride``: whether a cheap partition may run on a rank of another's
    (:func:`_riders`; False for schemes whose sides need ranks of their own)."""
    P = len(costs)
    costs = [float(c) for c in costs]
    if size < 1:
        raise LaunchError(f"a run needs at least 1 rank, not {size}")
    given = {p: r for p, r in enumerate(requested) if r is not None}
    for p, r in given.items():
        if r > n_owned[p]:
            raise LaunchError(f"partitions[{p}].ranks: {r} ranks for {n_owned[p]} owned nodes")
    if given:
        used = sum(given.values())
        free = [p for p in range(P) if p not in given]
        listed = ", ".join(f"partitions[{p}].ranks = {r}" for p, r in given.items())
        if not free and used != size:
            raise LaunchError(f"partitions[].ranks add up to {used} ({listed}) but {size} ranks "
                              f"were launched; run with -n {used} or change them")
        if used > size or (used + len(free) > size and not ride):
            raise LaunchError(f"partitions[].ranks ask for {used} ranks ({listed})"
                              + (f" and {len(free)} other partition(s) need one each, "
                                 f"{used + len(free)} in all (this scheme keeps its sides on "
                                 "ranks of their own)" if used <= size else "")
                              + f", but {size} were launched; run with -n "
                              f"{used + len(free) if used <= size else used} or lower them")
        # the most expensive of the others take the ranks left, one each; the
        # cheapest, for which none is left, ride on the least loaded rank
        order = sorted(free, key=lambda q: (-costs[q], q))
        keep = sorted(order[:size - used])
        counts = dict(given)
        counts.update(zip(keep, _share(size - used, [costs[p] for p in keep],
                                       [n_owned[p] for p in keep])))
        placed = [p for p in range(P) if p in counts]
        ranks_of = dict(zip(placed, _contiguous([counts[p] for p in placed])))
        _on_least_loaded(order[size - used:], costs, ranks_of, loads(
            [ranks_of[p] for p in placed], [costs[p] for p in placed], size))
        how = (f"{size} rank(s); partitions[].ranks given for "
               f"{', '.join(str(p) for p in given)}, the rest by {basis} cost"
               + "".join(f"; partition {p} runs on rank {ranks_of[p][0]} with another "
                         "partition's piece (no rank left for it)"
                         for p in sorted(order[size - used:])))
        return Assignment(tuple(ranks_of[p] for p in range(P)), tuple(costs), how, basis)
    if size >= P:
        counts = _share(size, costs, n_owned)
        idle = size - sum(counts)
        own = _contiguous(counts)
        riding = _riders(size, costs, n_owned, own) if ride else None
        if riding is not None:
            idle = size - len({r for rs in riding[0] for r in rs})
            return Assignment(riding[0], tuple(costs), f"{size} rank(s) for {P} partition(s), "
                              f"shared by {basis} cost; {riding[1]}"
                              + (f"; {idle} rank(s) idle (no partition has nodes to spare)"
                                 if idle else ""), basis)
        how = (f"{size} rank(s) for {P} partition(s), shared by {basis} cost"
               + (f"; {idle} rank(s) idle (no partition has nodes to spare)" if idle else ""))
        return Assignment(own, tuple(costs), how, basis)
    load, ranks_of = np.zeros(size), {}
    _on_least_loaded(range(P), costs, ranks_of, load)
    shown = [f"{1e3 * x:.3g} ms" if basis == "measured" else f"{x:.3g}" for x in load]
    how = (f"{size} rank(s) for {P} partitions: each partition on one rank, placed by "
           f"{basis} cost (rank loads {', '.join(shown)})")
    return Assignment(tuple(ranks_of[p] for p in range(P)), tuple(costs), how, basis)


def _on_least_loaded(parts, costs, ranks_of, load) -> None:
    """Each of ``parts``, most expensive first, on one rank: the least loaded
    of ``load`` (updated in place; a view limits the ranks), into ``ranks_of``."""
    for p in sorted(parts, key=lambda q: (-costs[q], q)):
        r = int(np.argmin(load))
        ranks_of[p] = (r,)
        load[r] += costs[p]


RIDE_GAIN = 0.9      # riders only when the slowest rank's load falls below this x the disjoint one's
RIDE_NODES = 1000    # ... and the others gain no rank that leaves a piece fewer owned nodes: a
#                      small partition's step is messages, not the nonzeros that the cost counts


def rank_sums(ranks_of, values, size: int) -> np.ndarray:
    """Every rank's sum of ``values[p]`` over the partitions p it serves."""
    out = np.zeros(size)
    for rs, v in zip(ranks_of, values):
        out[list(rs)] += v
    return out


def loads(ranks_of, costs, size: int) -> np.ndarray:
    """Every rank's predicted load: its partitions' costs, each divided by
    the partition's rank count."""
    return rank_sums(ranks_of, [c / len(rs) for rs, c in zip(ranks_of, costs)], size)


def _riders(size: int, costs, caps, own):
    """A cheap partition need not take a rank of its own: with N >= P ranks,
    the k cheapest partitions (k = 1 .. P-1) may each run on one rank of the
    others (the least loaded, most expensive rider first) while the others
    share all N ranks.  Returns (ranks, why) for the k whose slowest rank is
    least loaded, if that is below RIDE_GAIN x the disjoint assignment
    ``own``'s; else None.  (2 ranks, a dem partition of 97 % of the cost and
    a fem one of 3 %: the dem on both ranks and the fem with it on one, 0.53 x
    the slowest load of a rank each.)  A partition gains no rank by it that
    would leave its pieces fewer than RIDE_NODES owned nodes (``caps``: owned
    nodes)."""
    P = len(costs)
    best, best_load = None, loads(own, costs, size).max() * RIDE_GAIN
    order = sorted(range(P), key=lambda q: (costs[q], q))
    for k in range(1, P):
        riders, others = order[:k], sorted(order[k:])
        counts = _share(size, [costs[p] for p in others],
                        [max(len(own[p]), caps[p] // RIDE_NODES) for p in others])
        ranks_of = dict(zip(others, _contiguous(counts)))
        load = loads([ranks_of[p] for p in others], [costs[p] for p in others], size)
        _on_least_loaded(riders, costs, ranks_of, load[:sum(counts)])   # the others' ranks
        if load.max() < best_load:
            best, best_load = (tuple(ranks_of[p] for p in range(P)), riders), load.max()
    if best is None:
        return None
    ranks_of, riders = best
    total = sum(costs) or 1.0
    said = ", ".join(f"partition {p} ({100 * costs[p] / total:.0f} % of the cost) runs on "
                     f"rank {ranks_of[p][0]} with another partition's piece" for p in sorted(riders))
    return ranks_of, said + " rather than on a rank of its own"


def _share(n: int, costs, caps) -> list[int]:
    """n ranks over partitions: one each, the rest by cost (largest remainder),
    each at most its cap."""
    k = len(costs)
    counts = [1] * k
    extra = n - k
    total = sum(costs)
    if extra <= 0 or total <= 0:
        return counts
    want = np.array([n * c / total for c in costs])
    while extra > 0:
        room = [p for p in range(k) if counts[p] < caps[p]]
        if not room:
            break
        # the partition furthest below its share takes the next rank
        p = max(room, key=lambda q: (want[q] - counts[q], -q))
        counts[p] += 1
        extra -= 1
    return counts


def _contiguous(counts) -> tuple[tuple[int, ...], ...]:
    out, at = [], 0
    for c in counts:
        out.append(tuple(range(at, at + c)))
        at += c
    return tuple(out)


def communicators(world, assignment: Assignment):
    """{partition index: communicator} for the partitions this rank serves.

    One split of ``world`` serves all multi-rank partitions (their rank sets
    are disjoint); single-rank partitions use COMM_SELF."""
    from mpi4py import MPI  # lazy: importing mpi4py starts MPI; the entry point decides when
    mine = assignment.partitions_on(world.rank)
    multi = [p for p in mine if len(assignment.ranks[p]) > 1]
    color = multi[0] if multi else MPI.UNDEFINED
    sub = world.Split(color, world.rank)
    out = {}
    for p in mine:
        out[p] = sub if p in multi else MPI.COMM_SELF
    return out
