"""Build a run's share on this rank: scene -> model -> partitions -> scheme.

:func:`build` is what the runner and the monolithic reference call; it logs
what was built and what was left out, and returns an :class:`Assembly`.
"""
from __future__ import annotations

from dataclasses import dataclass

from solver.model import arrays as model_mod, element_steps
from solver.collective import on_root
from solver.driver import balance
from solver.model import layout as overlap
from solver.memory import release
from solver.petscutil import init
from solver.coupling.schemes import scheme_class
from solver.partitions import integrators, levels, partitioning
from solver.partitions.stability import UNCHECKED


def _silent(*_):
    pass


@dataclass
class Assembly:
    """Everything a run steps: the model (rank 0: all of it, unless it let go
    of it once shared out, :func:`solver.partitions.partitioning.lets_go`;
    other ranks: the cells and bonds touching their nodes), this rank's
    partitions and the coupling scheme (which owns the exchanges)."""

    model: object
    parts: list
    scheme: object
    freqs: dict
    scene: object = None          # the scene built (levels and time.dt made: resolve)
    counts: dict = None           # the whole model's FE cells and particles (model_counts)
    static: object = None         # analysis static: the StaticSolve standing in for the step

    def destroy(self):
        if self.static is not None:
            self.static.destroy()
        for part in self.parts:
            part.destroy()
        for exchange in self.scheme.exchanges:
            exchange.destroy()


MEASURE_WAIT = "-exchange_measure_wait"    # the command line's word for measure_wait


def model_counts(mdl, comm) -> dict:
    """FE cells and DEM particles of a continuum model (rank 0 holds it whole
    until the partitions stage)."""
    counts = {}
    if comm.rank == 0 and mdl.kind == "continuum":
        counts["fe_cells"] = sum(len(conn) for _, conn, _ in mdl.cells)
        zone = mdl.zone
        if zone is not None:
            counts["particles"] = zone.n_core + len(zone.band_points)
            counts["band_particles"] = len(zone.band_points)
    return comm.bcast(counts) if comm.size > 1 else counts


def run_flags(petsc_options) -> tuple[list, bool]:
    """(the PETSc options, measure_wait): ``-exchange_measure_wait`` among the
    options is the run option, not PETSc's."""
    options = list(petsc_options)
    return [o for o in options if o != MEASURE_WAIT], MEASURE_WAIT in options


def _model(scene, store):
    treatments = scheme_class(scene.coupling.scheme).treatments(scene)
    mdl = model_mod.build(scene, overlap.layer_counts(scene.partitions, treatments), store)
    if store is not None:
        store.built()               # (a one-run store lets go of the mesh)
    release()                       # the build's temporaries
    return mdl


def whole_model(scene, comm, store=None):
    """Rank 0's whole model of ``scene`` (None on the other ranks)."""
    return on_root(comm, _model, scene, store, share=False)


def resolve(scene, comm, store=None, say=_silent):
    """(the scene with its levels, time.dt and mass scaling made, rank 0's
    whole model or None): ``partitions: auto``, ``time.dt: auto`` and
    ``time.mass_scaling`` need the model (:mod:`solver.partitions.levels`);
    other scenes come back as they are, with no model."""
    if not levels.needs(scene):
        return scene, None

    def made():
        mdl = _model(scene, store)
        return levels.resolve(scene, mdl)
    out = on_root(comm, made, share=False)
    resolved, mdl, lines = out if out is not None else (None, None, ())
    for line in lines:
        say(f"[solver]   {line}")
    if comm.size > 1:
        resolved = comm.bcast(resolved)
    return resolved, mdl


def build(scene, comm, say=_silent, store=None, measure_wait: bool = False,
          model=None) -> Assembly:
    """Check the launch and the steps, then build this rank's share of the run
    (with ``balance: measured``, on the ranks of the measured costs:
    :mod:`solver.driver.balance`).  ``store``: the run's
    :class:`~solver.model.data.ModelData` (rank 0 builds the model from what
    binding read); ``measure_wait``: time the wait for the slower
    rank apart from each exchange (a barrier before it); ``model``: rank 0's
    model when :func:`resolve` built it (levels, scaled masses), plain or
    handed over as a :class:`~solver.partitions.partitioning.Whole`."""
    init()
    if isinstance(model, partitioning.Whole):       # handed over: no reference left with the caller
        model = model.take()
    prebuilt = bool(comm.allreduce(model is not None))
    if levels.needs(scene) and not prebuilt:
        scene, model = resolve(scene, comm, store, say)
        prebuilt = True
    size = comm.size
    n_part = len(scene.partitions)
    scheme_cls = scheme_class(scene.coupling.scheme)
    scheme_cls.check_launch(scene, size)
    treatments = scheme_cls.treatments(scene)
    R = scene.system_ratio
    n_sys = scene.n_system_steps
    Dt = scene.system_dt

    # the whole model on rank 0 only; the partitions stage sends every rank its share
    mdl = model if prebuilt else whole_model(scene, comm, store)
    if scene.analysis == "static":
        say(f"[solver] {scene.name}: static analysis on {size} rank(s): K u = f with the loads "
            f"at t = {scene.time.end:.6g} s")
    else:
        say(f"[solver] {scene.name}: {n_part} partition(s) on {size} rank(s); system step "
            f"{Dt:.4g} s = {R} x {scene.time.dt:.4g} s, {n_sys} system steps to t = "
            f"{n_sys * Dt:.6g} s")
    for note in mdl.notes if mdl is not None else ():
        say(f"[solver]   mesh {note}")
    if mdl is not None and mdl.zone is not None:
        say(f"[solver]   {mdl.zone.describe()}")
    if mdl is not None and say is not _silent:
        for line in element_steps.lines(scene, mdl):
            say(f"[solver]   {line}")
        release()                   # the element steps of every cell and bond
    counts = model_counts(mdl, comm)
    if scheme_cls.hands_over and partitioning.lets_go(scene, size) and mdl is not None:
        mdl, model = partitioning.Whole(mdl), None      # (no reference left here)
    scheme = scheme_cls.build(scene, mdl, comm, say)
    if scene.balance == "measured":          # timed, then kept or built again on other ranks
        scheme = balance.balanced(scene, scheme_cls, scheme, mdl, comm, say)
    if measure_wait:
        scheme.clocks.measure_wait()
    parts, freqs, mdl = scheme.parts, scheme.freqs, scheme.model
    lines = []
    for part in parts:
        fr, crit = freqs[part.name]
        lines.append(f"[solver]   {part.describe(stepping=fr is not UNCHECKED)}")
        ring = f"omega_max {fr.omega_max:.4g} rad/s ({fr.method}), critical step {crit:.4g} s" \
            if fr is not UNCHECKED else "no stability check (analysis static takes no step)"
        lines.append(f"[solver]   {part.name}: built {'; '.join(part.built)}; {ring}")
    for chunk in comm.gather(lines, root=0) or []:
        for line in chunk:
            say(line)

    if scene.analysis == "static":
        pass                         # (the static solve says what it is: solver.driver.static)
    elif scheme.exchanges:
        say(f"[solver]   {scheme.describe()}; {len(scheme.exchanges)} VecScatter exchange(s) of "
            f"(u, v, a) per system step; external-data treatment: "
            + ", ".join(f"{p.name} {t}" for p, t in zip(scene.partitions, treatments)))
    else:
        say(f"[solver]   {scheme.describe()}")
    not_built = []
    if not any(integrators.kind(p).needs_ksp for p in scene.partitions) and \
            scene.analysis == "dynamic":
        not_built.append("KSP (all partitions explicit)")
    if not scheme.exchanges and n_part == 1:
        not_built.append("exchange (single partition)")
    if not_built:
        say(f"[solver]   not built: {', '.join(not_built)}")
    scheme.initialise(mdl)          # (a scheme balance kept: the state it was put back to)
    return Assembly(mdl, parts, scheme, freqs, scene, counts)
