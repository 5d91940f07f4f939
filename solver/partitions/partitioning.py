"""The partitions stage: layouts, rank assignment, stability, this rank's pieces.

``build_partitions`` takes the model and the scheme's external-data
treatments and returns everything a coupling scheme needs to run on this
rank: the partition layouts (global), the rank assignment, every partition's
distribution over its ranks, this rank's partition pieces, and every
partition's frequency and critical step.  Unstable steps are refused here,
before stepping.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from solver.partitions import distribute
from solver.coupling import overlap
from solver.partitions import ranks
from solver.partitions import stability
from solver.coupling.overlap import csr
from solver.model.dofmap import ranges
from solver.partitions.dem import DemPartition
from solver.errors import StabilityError
from solver.partitions.fem import FemPartition

PARTITION_TYPES = {"fem": FemPartition, "dem": DemPartition}


@dataclass
class Partitions:
    layouts: list            # every partition's Layout
    assignment: object       # ranks.Assignment
    dists: list              # every partition's Distribution
    parts: list              # this rank's pieces, ascending partition order
    freqs: dict              # name -> (Frequency, critical step)


def build_partitions(scene, mdl, comm, treatments, say) -> Partitions:
    rank, size = comm.rank, comm.size
    R = scene.system_ratio
    neighbours = mdl.neighbours()
    graph = csr(neighbours)
    layouts = overlap.derive(neighbours, scene.partitions,
                             overlap.layer_counts(scene.partitions, treatments))
    costs = [ranks.cost(owned_nonzeros(graph, lay.owned, mdl.dofmap), R // p.ratio)
             for lay, p in zip(layouts, scene.partitions)]
    assignment = ranks.assign(size, costs, [lay.n_owned for lay in layouts],
                              [p.ranks for p in scene.partitions])
    for line in assignment.lines([p.name for p in scene.partitions]):
        say(line)
    local_ids = assignment.partitions_on(rank)
    # each partition's dense bound once, on its first rank
    freqs, problems = check_stability(scene, mdl, layouts,
                                      [p for p in local_ids if assignment.ranks[p][0] == rank])
    for chunk in comm.allgather(freqs):
        freqs.update(chunk)
    refuse(scene, sum(comm.allgather(problems), []), say)
    comms = ranks.communicators(comm, assignment)
    dists = [distribute.split(lay, neighbours, len(assignment.ranks[p]))
             for p, lay in enumerate(layouts)]
    parts = []
    for p in local_ids:
        piece = dists[p].pieces[assignment.ranks[p].index(rank)]
        parts.append(PARTITION_TYPES[scene.partitions[p].method](
            scene.partitions[p], piece, mdl, comms[p], treatments[p], scene.time.dt, R,
            scene.damping, dist=dists[p], graph=graph))
    check_large(scene, parts, freqs, comm, say)
    refuse(scene, [], say, freqs)
    return Partitions(layouts, assignment, dists, parts, freqs)


def check_stability(scene, mdl, layouts, ids):
    """({name: (Frequency, critical step)}, problems) of partitions ``ids``; numpy only."""
    freqs, problems = {}, []
    for p in ids:
        fr, crit, problem = stability.check(scene, scene.partitions[p], mdl, layouts[p].held)
        freqs[scene.partitions[p].name] = (fr, crit)
        if problem:
            problems.append(problem)
    return freqs, problems


def refuse(scene, problems, say, freqs=None):
    """Stop on unstable steps (guard.stable_step) or warn; with ``freqs``, warn
    about coupled implicit steps beyond the measured limit."""
    if problems and scene.guard.stable_step:
        raise StabilityError(problems[0])
    for problem in dict.fromkeys(problems):
        say(f"warning: {problem}; guard.stable_step is false, running anyway")
    if freqs is not None:
        for warning in coupled_step_warnings(scene, [{n: c for n, (_, c) in freqs.items()}]):
            say(f"warning: {warning}")


def check_large(scene, parts, freqs, comm, say):
    """Partitions too large for the dense check: the Gershgorin bound from their
    assembled operators (collective on each partition's ranks), then refuse."""
    local = {}
    for part in parts:
        if freqs.get(part.name, (None,))[0] is None:
            local[part.name] = stability.assembled(scene, part)
    problems = []
    for chunk in comm.allgather(local):
        for name, (fr, crit, problem) in chunk.items():
            freqs[name] = (fr, crit)
            if problem:
                problems.append(problem)
    refuse(scene, problems, say)


def owned_nonzeros(graph, owned, dofmap) -> int:
    """Nonzeros of the owned rows of a partition's operator over the node graph
    ``(indptr, indices)``: a node's DOFs times those of itself and its neighbours."""
    indptr, indices = graph
    counts = dofmap.counts
    deg = indptr[owned + 1] - indptr[owned]
    cols = indices[ranges(indptr[owned], deg)]
    reach = np.bincount(np.repeat(np.arange(owned.size), deg), weights=counts[cols],
                        minlength=owned.size) + counts[owned]
    return int((counts[owned] * reach).sum())


# Measured on 2D bars (README, "Stability at larger eta"): an implicit partition
# coupled to explicit ones stayed stable up to a step of 1.35x the explicit
# partitions' critical step and went unstable from 1.9x; 1D chains stay below 1x.
COUPLED_IMPLICIT_STEP = 1.4


def coupled_step_warnings(scene, crit_by_rank) -> list[str]:
    """Warnings for implicit partitions whose step exceeds COUPLED_IMPLICIT_STEP x
    the smallest critical step of the explicit partitions they are coupled to."""
    crit = {}
    for chunk in crit_by_rank:
        crit.update(chunk)
    explicit = [crit[p.name] for p in scene.partitions if p.integrator != "implicit" and p.name in crit]
    if not explicit or len(scene.partitions) < 2:
        return []
    limit = min(explicit)
    out = []
    for p in scene.partitions:
        dt = p.ratio * scene.time.dt
        if p.integrator == "implicit" and dt > COUPLED_IMPLICIT_STEP * limit:
            out.append(f"implicit partition '{p.name}' steps {dt:.4g} s, {dt / limit:.2f} x the "
                       f"critical step {limit:.4g} s of the explicit partitions it is coupled to; "
                       f"coupled schemes have been found unstable beyond ~{COUPLED_IMPLICIT_STEP}x "
                       "(the energy guard stops a blow-up)")
    return out
