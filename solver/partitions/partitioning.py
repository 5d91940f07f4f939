"""The partitions stage: layouts, rank assignment, stability, this rank's pieces.

``build_partitions`` takes the model and the scheme's external-data
treatments and returns everything a coupling scheme needs to run on this
rank (rank 0 plans from the node graph and sends each rank its slice of the
plan and its share of the model): every partition's owned node count, the
rank assignment, every partition's distribution over its ranks (this rank's
slice of it: :meth:`~solver.partitions.distribute.Distribution.slice_for`),
this rank's partition pieces, and every partition's frequency and critical
step.  Unstable steps are refused here,
before stepping.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from solver.collective import agree, idle, on_root, scatter_each
from solver.memory import release
from solver.partitions import distribute, integrators
from solver.model import layout as overlap
from solver.partitions import ranks
from solver.partitions import stability
from solver.partitions.dem import DemPartition
from solver.errors import SceneError, SolverError, StabilityError, describe
from solver.partitions.fem import FemPartition

PARTITION_TYPES = {"fem": FemPartition, "dem": DemPartition}


@dataclass
class Partitions:
    owned_counts: list       # every partition's owned nodes
    assignment: object       # ranks.Assignment
    dists: list              # every partition's Distribution (this rank's slice of it)
    parts: list              # this rank's pieces, ascending partition order
    freqs: dict              # name -> (Frequency, critical step)
    model: object            # this rank's share of the model (rank 0: all of it)


class Whole:
    """Rank 0's whole model handed to the partitions stage, which lets go of
    it once every rank has its share (:func:`lets_go`): the caller keeps no
    reference, so rank 0 builds its own pieces without the whole model in
    memory."""

    def __init__(self, model):
        self.model = model

    def take(self):
        model, self.model = self.model, None
        return model


def lets_go(scene, size: int) -> bool:
    """Whether rank 0 may let go of the whole model once it is shared out:
    on several ranks, a continuum model (a network's modal reference reads
    the whole stiffness), unless fields (the whole mesh) or ``balance:
    measured`` (which plans again) read it after set-up."""
    return (size > 1 and scene.model.kind == "continuum"
            and (scene.output is None or scene.output.fields is None)
            and scene.balance != "measured")


@dataclass
class Plan:
    """What rank 0 decides for everyone; each rank receives its slice."""
    owned_counts: list
    assignment: object
    dists: list              # every partition's Distribution (a rank's slice of it)
    freqs: dict              # dense stability of the partitions small enough for it
    problems: list


def plan(scene, mdl, size, treatments, assignment=None):
    """On one rank, with the whole model: what rank 0, 1, ... receive, made
    one at a time (:func:`slices` of :func:`decide`)."""
    whole, graph = decide(scene, mdl, size, treatments, assignment)
    return slices(whole, mdl, graph, size, [p.method for p in scene.partitions])


def decide(scene, mdl, size, treatments, assignment=None):
    """On one rank, with the whole model: the node graph, every partition's
    layout, the rank assignment (by estimated cost, unless ``assignment`` is
    given: a :class:`~solver.partitions.ranks.Assignment` by measured cost),
    every partition's distribution over its ranks and the dense stability
    check.  Returns (the whole Plan, the node graph)."""
    R = scene.system_ratio
    graph = mdl.graph()
    layouts = overlap.derive(graph, scene.partitions,
                             overlap.layer_counts(scene.partitions, treatments))
    if assignment is None:
        costs = [ranks.cost(owned_nonzeros(graph, lay.owned, mdl.dofmap), R // p.ratio)
                 for lay, p in zip(layouts, scene.partitions)]
        assignment = ranks.assign(size, costs, [lay.n_owned for lay in layouts],
                                  [p.ranks for p in scene.partitions],
                                  ride=scene.scheme.rides)
    dists = [distribute.split(lay, graph, len(assignment.ranks[p]))
             for p, lay in enumerate(layouts)]
    freqs, problems = check_stability(scene, mdl, layouts, range(len(layouts)))
    return Plan([lay.n_owned for lay in layouts], assignment, dists, freqs, problems), graph


def slices(whole, mdl, graph, size, methods):
    """Every rank's (slice of the plan ``whole``, share of the model), made
    when asked for (rank 0 holds one other rank's at a time).  A rank's slice
    has the pieces it steps and the distributed numbering of their nodes and
    their neighbours in the node ``graph`` (all its share's cells and bonds
    reach); on one rank the plan is whole.  Rank 0 gets the whole model (it builds its
    own share later); rank r > 0 the model's cells and bonds of the nodes it
    holds (no body cells where it steps no fem partition: ``methods``, every
    partition's)."""
    if size == 1:
        yield whole, mdl
        return
    starts = [dist.piece_dofs(mdl.dofmap) for dist in whole.dists]     # (every rank's)
    for r in range(size):
        dists = []
        for p, dist in enumerate(whole.dists):
            on = whole.assignment.ranks[p]
            k = on.index(r) if r in on else None
            near = graph.reach(dist.pieces[k].held) if k is not None else None
            dists.append(dist.slice_for(k, near, mdl.dofmap, starts[p]))
        mine = Plan(whole.owned_counts, whole.assignment, dists, whole.freqs, whole.problems)
        yield mine, (mdl if r == 0 else share_of(mdl, whole.dists, whole.assignment, r, methods))


def share_of(mdl, dists, assignment, rank, methods):
    """The model's cells and bonds of the nodes world ``rank`` holds."""
    held = distribute.held_on(dists, assignment, rank)
    fem = any(methods[p] == "fem" for p in assignment.partitions_on(rank))
    return mdl.share(held, body_cells=fem)


def build_error(name: str, e: Exception) -> SceneError:
    """What a PETSc error while building partition ``name`` tells the user
    (its options are the likely cause)."""
    return SceneError(f"partition '{name}': PETSc could not build it "
                      f"({describe(e)}); check the -{name}_ options")


def build_partitions(scene, mdl, comm, treatments, say, assignment=None) -> Partitions:
    """Rank 0 plans with the whole model (``mdl``; other ranks pass None); every
    rank gets only its slice of the plan and its share of the model, then
    builds its pieces.  ``mdl`` a :class:`Whole`: rank 0 keeps only its share
    (the returned model).  ``assignment``: the ranks to use instead of
    those by estimated cost (:mod:`solver.driver.balance`)."""
    rank, size = comm.rank, comm.size
    R = scene.system_ratio
    handed = isinstance(mdl, Whole)
    if handed:
        mdl = mdl.take()
    items = on_root(comm, plan, scene, mdl, size, treatments, assignment, share=False)
    decided, mdl = scatter_each(comm, items) if size > 1 else next(items)
    del items
    release()                    # rank 0: the whole plan, graph and planning temporaries
    owned_counts, assignment, dists, freqs = (decided.owned_counts, decided.assignment,
                                              decided.dists, dict(decided.freqs))
    # rank 0 builds its pieces from its share, as the others do (from the whole
    # model every mask and selection would run over all cells and bonds); it
    # keeps the whole model for what reads it after set-up (fields, counts)
    whole = mdl
    if size > 1 and rank == 0:
        mdl = share_of(whole, dists, assignment, 0, [p.method for p in scene.partitions])
        if handed:
            whole = mdl              # the whole model's cells and bonds go here
            release()
    if handed and size > 1:
        say("[solver]   rank 0 keeps only its share of the model once shared out (no fields "
            "or measured balance read it whole)")
    for line in assignment.lines([p.name for p in scene.partitions]):
        say(line)
    refuse(scene, decided.problems, say, sides=decided.freqs)
    comms = ranks.communicators(comm, assignment)
    built, error, name = {}, None, "?"
    # pieces of split partitions first: building one is collective on its ranks,
    # so a rank that fails on a partition of its own (one riding beside another's
    # piece) must have joined every collective build before it stops
    mine = sorted(assignment.partitions_on(rank), key=lambda q: (len(assignment.ranks[q]) == 1, q))
    try:
        for p in mine:
            name = scene.partitions[p].name
            piece = distribute.piece_on(dists, assignment, p, rank)
            built[p] = PARTITION_TYPES[scene.partitions[p].method](
                scene.partitions[p], piece, mdl, comms[p], treatments[p], scene.time.dt, R,
                scene.damping, dist=dists[p])
    except SolverError as e:
        error = e
    except Exception as e:                      # noqa: BLE001 -- PETSc errors from options
        error = build_error(name, e)
    parts = [built[p] for p in sorted(built)]
    try:
        agree(comm, error)
        check_large(scene, parts, freqs, comm, say)
        release()                    # the stability estimates' vectors
        refuse(scene, scene.scheme.built_problems(scene, freqs), say, freqs,
               dropped=scene.scheme.dropped)
    except BaseException:
        for part in parts:           # refused after building: free the PETSc objects
            part.destroy()
        raise
    return Partitions(owned_counts, assignment, dists, parts, freqs, whole)


def check_stability(scene, mdl, layouts, ids):
    """({name: (Frequency, critical step)}, problems) of partitions ``ids``; numpy only.
    A static analysis takes no step: nothing is checked (stability.UNCHECKED)."""
    if scene.analysis == "static":
        return {scene.partitions[p].name: (stability.UNCHECKED, float("inf")) for p in ids}, []
    freqs, problems = {}, []
    for p in ids:
        fr, crit, problem = stability.check(scene, scene.partitions[p], mdl, layouts[p].held,
                                            layouts[p].n_owned)
        freqs[scene.partitions[p].name] = (fr, crit)
        if problem:
            problems.append(problem)
    return freqs, problems


def refuse(scene, problems, say, freqs=None, sides=None, dropped="running anyway"):
    """Stop on unstable steps (guard.stable_step) or warn (``dropped``: what
    running anyway gives up); with ``freqs``, warn about coupled implicit steps
    beyond the measured limit.  ``sides``: the critical steps known so far,
    for the scheme's account of them (its refusal_context)."""
    context = scene.scheme.refusal_context(scene, sides) if problems and sides else None
    if context:
        problems = [p + "; " + context for p in problems]
    if problems and scene.guard.stable_step:
        raise StabilityError(problems[0])
    for problem in dict.fromkeys(problems):
        say(f"warning: {problem}; guard.stable_step is false: {dropped}")
    if freqs is not None:
        for warning in coupled_step_warnings(scene, [{n: c for n, (_, c) in freqs.items()}]):
            say(f"warning: {warning}")


def check_large(scene, parts, freqs, comm, say):
    """Partitions too large for the dense check: the Gershgorin bound from their
    assembled operators (collective on each partition's ranks), then refuse."""
    local = {}
    # split partitions first (collective on their ranks), as they were built
    for part in sorted(parts, key=lambda q: q.comm.size == 1):
        if freqs.get(part.name, (None,))[0] is None:
            local[part.name] = stability.assembled(scene, part)
    problems = []
    idle(comm)                   # (a partition's check may take far longer than another's)
    for chunk in comm.allgather(local):
        for name, (fr, crit, problem) in chunk.items():
            freqs[name] = (fr, crit)
            if problem:
                problems.append(problem)
    refuse(scene, problems, say, sides=freqs)


def owned_nonzeros(graph, owned, dofmap) -> int:
    """Nonzeros of the owned rows of a partition's operator over the node graph
    (:class:`~solver.model.graph.Graph`): a node's DOFs times those of itself and
    its neighbours (the neighbours read in chunks: the whole dem partition's
    lists at once were a quarter of a GB of rank 0's planning on the 2.27 M-DOF
    bar)."""
    counts = dofmap.counts
    owned = np.asarray(owned, dtype=np.int64)
    reach = graph.neighbour_sums(owned, counts, NONZERO_CHUNK) + counts[owned]
    return int((counts[owned] * reach).sum())


NONZERO_CHUNK = 65536           # nodes whose neighbour lists owned_nonzeros reads at a time


# Measured on 2D bars (docs/benchmarks/papers.md, "Stability at larger η"): an implicit partition
# coupled to explicit ones stayed stable up to a step of 1.35x the explicit
# partitions' critical step and went unstable from 1.9x; 1D chains stay below 1x.
COUPLED_IMPLICIT_STEP = 1.4


def coupled_step_warnings(scene, crit_by_rank) -> list[str]:
    """Warnings for implicit partitions whose step exceeds COUPLED_IMPLICIT_STEP x
    the smallest critical step of the explicit partitions they are coupled to."""
    crit = {}
    for chunk in crit_by_rank:
        crit.update(chunk)
    explicit = [crit[p.name] for p in scene.partitions if not integrators.kind(p).implicit
                and p.name in crit]
    if not explicit or len(scene.partitions) < 2:
        return []
    limit = min(explicit)
    out = []
    for p in scene.partitions:
        dt = p.ratio * scene.time.dt
        if integrators.kind(p).implicit and dt > COUPLED_IMPLICIT_STEP * limit:
            step, critical = stability.seconds(dt, limit)
            out.append(f"implicit partition '{p.name}' steps {step} s, {dt / limit:.2f} x the "
                       f"critical step {critical} s of the explicit partitions it is coupled to; "
                       f"coupled schemes have been found unstable beyond ~{COUPLED_IMPLICIT_STEP}x "
                       "(the energy guard stops a blow-up)")
    return out
