"""Ranks shared by measured cost (``balance: measured``): a calibration before the run.

The scheme is first built as always, its ranks shared by estimated cost
(:mod:`solver.partitions.ranks`).  From the initial state it then steps one
system step to warm up and ``balance_steps`` more, timed: each partition's
wall per system step (the slowest of its pieces) times its ranks is its
measured cost, and :func:`solver.partitions.ranks.assign` shares the ranks by
those costs.  If that changes the assignment, the partitions are built again
on their new ranks (a fresh build, as an estimated run with that assignment
would be); if not, the initial state is put back (:func:`solver.driver.state.restore`,
what a checkpoint holds).  Either way the run proper starts from the initial
state: its answers are those of an estimated run with the same assignment
(and across assignments they agree to round-off, as on any rank count).

The log shows each partition's measured wall per system step and each rank's
predicted wait for the slowest rank (its time minus the slowest rank's),
before (measured on the estimated assignment) and after (the measured costs
divided over the new ranks).  Where nothing can change, nothing is timed and
the log says why: one rank, one rank per partition (N = P), every partition's
``partitions[].ranks`` given, or a scheme that places its partitions itself.
"""
from __future__ import annotations

import numpy as np

from solver.collective import on_root
from solver.driver import state
from solver.partitions import ranks


def _silent(*_):
    pass


def cannot_change(scene, scheme, size: int) -> str | None:
    """Why the assignment cannot change on ``size`` ranks (None: it can)."""
    P = len(scene.partitions)
    if scheme.assignment is None:
        return f"coupling.scheme {scene.coupling.scheme} places its partitions on ranks itself"
    if size == 1:
        return "one rank serves every partition"
    if P == 1:
        return "one partition: it has every rank"
    one_each = sorted(scheme.assignment.ranks) == [(r,) for r in range(size)]
    if size == P and one_each and not (scene.scheme.rides and any(
            n >= 2 * ranks.RIDE_NODES for n in scheme.owned_counts)):
        # (a cheap partition could ride beside a piece of a large one: timed)
        return f"{size} ranks for {P} partitions: one rank each"
    if all(p.ranks is not None for p in scene.partitions):
        return "partitions[].ranks gives every partition's ranks"
    return None


def balanced(scene, scheme_cls, scheme, mdl, comm, say):
    """The scheme to run with ``balance: measured``: ``scheme`` itself (built by
    estimated cost; initialised, its initial state put back after the timing) or
    the scheme built again on the ranks of the measured costs (not initialised).
    ``mdl``: the model as the first build had it (rank 0: all of it)."""
    why = cannot_change(scene, scheme, comm.size)
    if why:
        say(f"[solver] balance: measured: nothing to time, {why}; the ranks stay as estimated")
        return scheme
    scheme.initialise(scheme.model)
    initial = comm.bcast(state.collect(0, scheme.parts, None, comm, scheme))
    walls, failure = measure(scheme, scene.balance_steps, scene.system_dt, comm)
    before = scheme.assignment
    after, lines = on_root(comm, decide, scene, before, scheme.owned_counts,
                           walls, failure, comm.size)
    for line in lines:
        say(line)
    if after.ranks == before.ranks:
        for part in scheme.parts:
            part.wall, part.failed = 0.0, False
        scheme.clocks.exchange_wall = 0.0
        scheme.clocks.failures.clear()
        state.restore(initial, scheme.parts, scheme, None)
        return scheme
    for part in scheme.parts:
        part.destroy()
    for exchange in scheme.exchanges:
        exchange.destroy()
    return scheme_cls.build(scene, mdl, comm, _silent, assignment=after)


def measure(scheme, steps: int, Dt: float, comm):
    """Step ``scheme`` one system step (to warm up: first calls compile and
    allocate), then ``steps`` more, timed.  Returns on rank 0 ([{partition index:
    wall per system step}] of every rank's pieces, the first failure of a
    partition on any rank or None), (None, None) elsewhere."""
    parts = scheme.parts
    scheme.step(0.0)
    start = [part.wall for part in parts]
    for s in range(1, steps + 1):
        scheme.step(s * Dt)
    local = {part.layout.index: (part.wall - w0) / steps for part, w0 in zip(parts, start)}
    failures = scheme.clocks.failures
    mine = (local, failures[0] if failures else None)
    gathered = comm.gather(mine, root=0) if comm.size > 1 else [mine]
    if gathered is None:
        return None, None
    return [w for w, _ in gathered], next((f for _, f in gathered if f), None)


def decide(scene, before, n_owned, walls, failure, size: int):
    """(the assignment to run with, the log lines) from ``walls`` ([{partition
    index: s per system step}] per rank) measured on assignment ``before``."""
    names = [p.name for p in scene.partitions]
    P = len(names)
    lines = [f"[solver] balance: measured, each partition's wall per system step over "
             f"{scene.balance_steps} system step(s) from the initial state (after one to warm up)"]
    if failure:
        lines.append(f"[solver]   a partition failed while timed ({failure}); the ranks stay as "
                     "estimated")
        return before, lines
    wall = [max(w.get(p, 0.0) for w in walls) for p in range(P)]     # its slowest piece
    lines += _walls("before", names, before, wall, "")
    lines.append(_waits("before", [sum(w.values()) for w in walls]))
    costs = [ranks.measured_cost(wall[p], len(before.ranks[p])) for p in range(P)]
    after = ranks.assign(size, costs, n_owned, [p.ranks for p in scene.partitions], "measured",
                         ride=scene.scheme.rides)
    lines += after.lines(names)
    predicted = [c / len(rs) for c, rs in zip(costs, after.ranks)]
    lines += _walls("after", names, after, predicted, "predicted ")
    lines.append(_waits("after", after.rank_times(predicted, size), "predicted "))
    lines.append("[solver]   balance: " + (
        "the assignment is unchanged; the run starts from the initial state put back"
        if after.ranks == before.ranks else
        "the assignment changed; the partitions are built again on these ranks"))
    return after, lines


def _walls(when, names, assignment, wall, what) -> list[str]:
    return [f"[solver]   {when}: {name}: {ranks.span(rs)} ({len(rs)}), {what}{_ms(w)} ms per "
            "system step" for name, rs, w in zip(names, assignment.ranks, wall)]


def _waits(when, times, what="") -> str:
    times = np.asarray(times, dtype=float)
    slowest = times.max(initial=0.0)
    wait = ranks.waits(times)
    wait[wait <= 1e-9 * slowest] = 0.0              # round-off of the predicted division
    return (f"[solver]   {when}: {what}wait per rank for the slowest "
            f"{' / '.join(_ms(w) for w in wait)} ms per system step (slowest rank "
            f"{_ms(slowest)} ms)")


def _ms(seconds: float) -> str:
    return f"{1e3 * seconds:.3g}"
