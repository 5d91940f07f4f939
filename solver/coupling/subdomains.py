"""The Gravouil-Combescure subdomains (``coupling.scheme: gc``) and their ranks.

A non-overlapping decomposition derived from the scene's node ownership: an
*interface node* is a node of the coarse (implicit) partition with a spring to
the fine (explicit) partition.  Both subdomains hold a copy of it with half its
mass; the fine subdomain takes every spring touching one of its own nodes,
the coarse one the rest; loads on interface nodes stay with the coarse side.

Rank 0 (the whole model) plans, as the partitions stage does for the other
schemes (:mod:`solver.partitions.partitioning`): the two subdomain models and
layouts, the rank assignment (:func:`solver.partitions.ranks.assign` by
estimated cost, ``partitions[].ranks`` honoured, or the assignment given by
``balance: measured``), each subdomain's distribution over its ranks
(:func:`solver.partitions.distribute.split`: RCM order cut into slabs; on one
rank the node order of the single-rank scheme) and the dense stability check
of each subdomain.  Every rank gets the plan and only its share: the springs
of its subdomain that touch its nodes (each matrix is preallocated from the
blocks it holds).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from solver.collective import on_root, scatter_each
from solver.errors import StabilityError
from solver.model.layout import Layout
from solver.partitions import distribute, integrators, ranks, stability
from solver.partitions.partitioning import owned_nonzeros

NOTE = "GC subdomain, interface mass halved"


def subdomains(scene, mdl):
    """(models, layouts, interface nodes, (a, b)) of the fine (A) and coarse (B)
    subdomains; a, b: their partitions' indices in the scene."""
    parts = scene.partitions
    b = next(k for k, p in enumerate(parts) if integrators.kind(p).implicit)
    a = 1 - b
    nodes = [np.sort(np.asarray(p.nodes, dtype=np.int64)) for p in parts]
    in_a = np.zeros(mdl.n_nodes + 1, bool)
    in_a[nodes[a]] = True
    si, sj = mdl.spring_i, mdl.spring_j
    touches_a = in_a[si] | in_a[sj]              # index -1 (ground) reads the extra slot
    iface = np.unique(np.concatenate([sj[in_a[si] & ~in_a[sj] & (sj >= 0)],
                                      si[in_a[sj] & ~in_a[si] & (si >= 0)]]))
    mass_half = mdl.mass.copy()
    mass_half[iface] *= 0.5
    on_iface = set(iface.tolist())
    model_a = dataclasses.replace(
        mdl, mass=mass_half, spring_i=si[touches_a], spring_j=sj[touches_a],
        spring_k=mdl.spring_k[touches_a],
        loads=tuple(l for l in mdl.loads if int(mdl.dofmap.node_of(l.dof)[0]) not in on_iface))
    model_b = dataclasses.replace(mdl, mass=mass_half, spring_i=si[~touches_a],
                                  spring_j=sj[~touches_a], spring_k=mdl.spring_k[~touches_a])
    held_a = np.concatenate([nodes[a], iface])
    empty = np.zeros(0, dtype=np.int64)

    def layout(name, index, held):
        return Layout(name, index, held, empty, held, (), empty)
    return ((model_a, model_b), (layout(parts[a].name, a, held_a), layout(parts[b].name, b, nodes[b])),
            iface, (a, b))


@dataclass
class Plan:
    """What rank 0 decides for every rank (small arrays, broadcast)."""
    index: tuple             # (a, b): scene indices of the fine and coarse partitions
    iface: np.ndarray        # interface nodes (sorted global ids)
    layouts: list            # both subdomains' Layouts, scene order
    assignment: object       # ranks.Assignment
    dists: list              # both subdomains' Distributions, scene order
    freqs: dict              # name -> (Frequency, critical step); (None, None): too large,
    #                          decided from the assembled operator


def plan(scene, mdl, size: int, assignment=None):
    """On rank 0, with the whole model: (Plan, [(its shares {partition: model}, the
    model the scheme keeps)] for every rank).  An unstable step
    raises StabilityError (the dense check; ``NOTE`` appended)."""
    models, lays, iface, (a, b) = subdomains(scene, mdl)
    specs = scene.partitions
    model = {a: models[0], b: models[1]}
    layouts = [lays[0], lays[1]] if a == 0 else [lays[1], lays[0]]
    graphs = [model[p].graph() for p in range(2)]
    if assignment is None:
        R = scene.system_ratio
        costs = [ranks.cost(owned_nonzeros(graphs[p], layouts[p].owned, mdl.dofmap),
                            R // specs[p].ratio) for p in range(2)]
        assignment = ranks.assign(size, costs, [lay.n_owned for lay in layouts],
                                  [p.ranks for p in specs], ride=scene.scheme.rides)
    # one rank: the node order of the single-rank scheme; several: as every partition
    dists = [distribute.split(layouts[p], graphs[p], len(assignment.ranks[p]), order=size > 1)
             for p in range(2)]
    freqs = {}
    for p in (a, b):                      # the fine side first, as it is built first
        fr, crit, problem = stability.check(scene, specs[p], model[p], layouts[p].held)
        if problem:
            raise StabilityError(f"{problem} ({NOTE})")
        freqs[specs[p].name] = (fr, crit)
    shares = [({p: model[p] for p in assignment.partitions_on(0)}, mdl)]
    for r in range(1, size):
        mine = {}
        for p in assignment.partitions_on(r):
            nodes = distribute.piece_on(dists, assignment, p, r).held
            mine[p] = model[p].share(nodes)
        shares.append((mine, mdl.share(distribute.held_on(dists, assignment, r))))
    return Plan((a, b), iface, layouts, assignment, dists, freqs), shares


def place(scene, mdl, comm, assignment=None):
    """Collective: (the Plan, this rank's shares {partition: model}, the
    model this rank keeps).  ``mdl``: the whole model on rank 0, None elsewhere."""
    decided, shares = on_root(comm, plan, scene, mdl, comm.size, assignment,
                              share=False) or (None, None)
    if comm.size > 1:
        decided = comm.bcast(decided)
        mine, kept = scatter_each(comm, shares)
    else:
        (mine, kept), = shares
    return decided, mine, kept


def owned_rows(part, nodes) -> tuple[np.ndarray, np.ndarray]:
    """(local rows, positions in ``nodes``) of the ``nodes`` this piece owns
    (networks: one DOF per node)."""
    loc = part.layout.local(nodes)
    mine = (loc >= 0) & (loc < part.layout.n_owned)
    return loc[mine].astype(np.int64), np.flatnonzero(mine)
