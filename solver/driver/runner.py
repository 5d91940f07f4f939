"""One run of a scene: build (:mod:`solver.driver.build`), step, watch, record, report.

What a system step does is the coupling scheme's business
(:mod:`solver.coupling.system_step`, :mod:`solver.coupling.gc`); which rank holds what is
:mod:`solver.partitions.partitioning`'s; what is watched while stepping is
:mod:`solver.driver.monitor`'s; the step loop tells its observers
(:mod:`solver.driver.observers`) about every system step; checkpoints are
:mod:`solver.driver.checkpoint`'s, what a run reports :mod:`solver.driver.report`'s.
"""
from __future__ import annotations

import os
import signal
import time

import numpy as np

from solver.model import layout as overlap
from solver.partitions.partitioning import Whole
from solver.driver.build import build, resolve, whole_model
from solver.driver.comparison import add_reference, check_reference
from solver.errors import RunFailed, SceneError, StabilityError, describe
from solver.driver.checkpoint import Checkpoint
from solver.driver.monitor import EnergyGuard, Probes
from solver.driver.observers import Progress, hooks
from solver.driver.report import Report, RunResult
from solver.driver import output, state, stress, provenance as prov
from solver.driver.heating import Heating
from solver.petscutil import check_unused
from solver.driver.stop import Stopper, Interrupted
from solver.driver.fields import FieldWriter, write_cracks
from solver.driver.state import group_writer
from solver.driver.static import StaticSolve, one_sample, preloaded


def _silent(*_):
    pass


def run(scene, comm=None, log=print, scene_text: str = "", restart: str | None = None,
        provenance: dict | None = None, overwrite: bool = False,
        check_options: bool = False, store=None, measure_wait: bool = False) -> RunResult:
    """Run ``scene`` on ``comm`` (default COMM_WORLD); rank 0 writes the output.

    ``restart``: an output file with a checkpoint of this scene; the run goes on
    from there (on any rank count).  ``provenance``: extra root attributes
    (:mod:`solver.driver.provenance`; versions and commit are always written).
    ``overwrite``: a fresh run may replace an output file that holds a
    checkpoint (refused otherwise).  ``check_options``: PETSc options that no
    object of the built run uses are refused before stepping (the command
    line's choice; scripts may set options for other objects of their own).
    ``store``: the :class:`~solver.model.data.ModelData` the scene was bound with
    (the model build reuses it; None: read afresh).  ``measure_wait``: a barrier
    before every exchange, timing the wait for the slower rank apart
    (``exchange_wait_time_per_rank``; ``-exchange_measure_wait`` on the command line)."""
    from mpi4py import MPI  # lazy: importing mpi4py starts MPI; the entry point decides when

    t_start = time.perf_counter()
    comm = comm or MPI.COMM_WORLD
    rank = comm.rank
    say = log if rank == 0 else _silent
    scene, model = resolve(scene, comm, store, say)      # partitions / time.dt: auto, mass scaling
    saved = state.read(restart, scene, comm) if restart else None
    problem = comm.bcast(output.check_writable(scene.output_file, restart, overwrite)
                         if rank == 0 else None)
    if problem:
        raise SceneError(problem)
    if getattr(scene.reference, "kind", "") == "monolithic":
        problem = None
        if rank == 0:
            try:
                check_reference(scene)
            except StabilityError as e:
                problem = e
        problem = comm.bcast(problem)
        if problem:
            raise problem
    if scene.preload == "static" and not saved:       # (a restart goes on from its checkpoint)
        if not comm.allreduce(model is not None):
            model = whole_model(scene, comm, store)
        model = preloaded(scene, comm, say, model)
    handed = Whole(model)            # build takes it: rank 0 may let go of the whole model
    del model
    asm = build(scene, comm, say, store, measure_wait, handed)
    if scene.analysis == "static":
        try:
            asm.static = StaticSolve(scene, asm, say)
        except BaseException:
            asm.destroy()
            raise
        asm.scheme.step = asm.static.step          # the one system step: the solve
    mdl, parts, scheme = asm.model, asm.parts, asm.scheme
    n_sys, Dt = scene.n_system_steps, scene.system_dt

    owner = overlap.owner_map(mdl.n_nodes, scene.partitions)
    probes = Probes(scene.probes, parts, owner, n_sys, mdl.points,
                    stress.build(scene, mdl, parts))
    for probe in scene.probes:
        if probe.at is not None:
            xyz = np.asarray(mdl.points[probe.node], dtype=float)
            gap = np.linalg.norm(xyz - np.asarray(probe.at, dtype=float)[:xyz.size])
            say(f"[solver]   probe {probe.name}: at {list(probe.at)} -> node {probe.node} at "
                f"{[float(f'{c:.6g}') for c in xyz]} ({gap:.3g} m away)")
    heating = None
    if mdl.heat is not None:
        heating = Heating(mdl.heat, parts, scene)
        say(f"[solver]   {heating.describe()}")
        if probes.stress is not None:
            probes.stress.heating = heating
    every = energy_every(scene)
    guard = EnergyGuard(parts, comm, Dt, every, scene.guard.energy_bound,
                        scene.guard.max_displacement or body_size(mdl, comm),
                        mdl.points.shape[1] if mdl.points is not None else None)
    start = 0
    if saved:
        start = saved["step"]
        state.restore(saved, parts, scheme, guard)
        probes.restore(saved["probes"], start)
        if heating is not None and saved.get("heat") is not None:
            heating.restore(saved["heat"])
        say(f"[solver] restarted from {restart} at system step {start} (t = {start * Dt:.6g} s)")
    report = Report(scene, asm, probes, guard, comm, scene_text, t_start, heating)
    report.extra = {"versions": prov.versions(), "commit": prov.commit(), **asm.counts,
                    **(provenance or {})}
    if check_options:
        check_unused(comm, [p.name for p in scene.partitions])
    report.setup_wall = time.perf_counter() - t_start
    # from the first write on, an interrupt is a flag the step loop polls (the
    # output is kept); a second one stops at once
    with Stopper(comm, start) as stop:
        return _stepped(scene, comm, say, asm, probes, guard, heating, report, stop, start)


def _stepped(scene, comm, say, asm, probes, guard, heating, report, stop, start):
    """The run from its first output on: checkpoint, fields, stepping, the final output."""
    rank, mdl, parts, scheme = comm.rank, asm.model, asm.parts, asm.scheme
    Dt = scene.system_dt
    spec = scene.output.checkpoint if scene.output else None
    checkpoint = Checkpoint(spec.every, scene, parts, guard, comm, report) if spec else None
    if checkpoint:
        checkpoint.write(start, 0.0)

    fields = None
    if scene.output and scene.output.fields:
        fields = FieldWriter(scene, mdl, parts, comm, tag=f"_restart{start}" if start else "",
                             heating=heating)
        if asm.static is None:       # (a static run's fields hold the static state alone)
            fields.write(start * Dt)
    # in the order they see a system step: a guard failure writes no checkpoint
    observers = [o for o in (heating, probes, fields, guard, checkpoint) if o is not None]
    progress = scene.output.progress if scene.output else 10.0
    if rank == 0 and progress:
        observers.append(Progress(say, progress, guard, Dt))
    stop.where = "stepping"
    try:
        failure, done, loop_wall, interrupted = step_loop(
            scheme, observers, stop, start, scene.n_system_steps, Dt, comm.rank)
    finally:
        if fields:
            fields.close()
        if heating:
            heating.destroy()
        probes.destroy()
    stop.where = "while writing the output"

    result = report.result(done, "failed" if failure else "completed", failure or "", loop_wall)
    if asm.static is not None:
        result = one_sample(result)
    if fields and rank == 0:
        written = fields.written()
        if result.broken is not None and len(result.broken):
            written += write_cracks(scene.output_file, result.broken, mdl.points.shape[1])
        result.attrs["field_files"] = np.array(written, dtype=object)
    if scene.reference != "none" and not failure and result.probes:
        add_reference(result, mdl, scene, comm, say)
    # a completed run keeps its final state (restart with a later time.end to go on);
    # a failed one keeps its last good checkpoint
    final = checkpoint.final(done, failure) if checkpoint else None
    asm.destroy()
    if rank == 0:
        output.write(scene.output_file, result, checkpoint=group_writer(final))
    comm.barrier()
    if failure:
        raise (Interrupted if interrupted else RunFailed)(
            f"{scene.name}: {failure}; output marked failed: {scene.output_file}")
    late = stop.signals()
    if late:
        raise Interrupted(f"{scene.name}: interrupted ({late}) after the last system step, "
                          f"while writing the output; the output is complete: {scene.output_file}")
    return result


def energy_every(scene) -> int:
    """System steps between energy samples: output.energy_every, or at least 100
    samples per run, at most one per 10 system steps once a run has 1000 of
    them, and at most ~2000 samples (a sample costs a MatMult per partition)."""
    if scene.output and scene.output.energy_every:
        return scene.output.energy_every
    n = scene.n_system_steps
    return max(1, n // 2000, min(10, n // 100))


def body_size(mdl, comm) -> float | None:
    """The largest extent of a continuum's nodes (the lost-particle bound), or None."""
    size = None
    if comm.rank == 0 and mdl.points is not None:
        size = float(np.ptp(mdl.points, axis=0).max())
    return comm.bcast(size) if comm.size > 1 else size


def step_loop(scheme, observers, stop, start: int, n_steps: int, dt: float, rank: int = 0):
    """Advance system steps from ``start`` to ``n_steps``, telling the ``observers``
    (:mod:`solver.driver.observers`; probes, guard, fields, heating, checkpoints,
    progress) about each, until the end, an observer's failure, a partition's
    failure or an interrupt on any rank (all ranks stop at the same step,
    :mod:`solver.driver.stop`: ``stop``, the run's Stopper, holds the signals and
    failures).

    Returns (failure message or None, system steps done, stepping wall time,
    interrupted)."""
    clock = time.perf_counter
    for ob in observers:
        ob.start(start, n_steps)
    t_loop = clock()
    failure, k, interrupted = None, start, False
    failures = scheme.clocks.failures
    # fault injection for the tests: rank 0 sends itself SIGTERM after this system step
    kill_at = int(os.environ.get("MTS_SIGTERM_AT_STEP", "-1")) if rank == 0 else -1
    before, stepped, polls, after = (hooks(observers, name) for name in
                                     ("before_step", "stepped", "needs_poll", "after_step"))
    for s in range(start, n_steps):
        try:
            for hook in before:
                hook(s)
            scheme.step(s * dt)
            for hook in stepped:
                hook(s + 1)
        except Exception as e:              # noqa: BLE001 -- stop together, keep the output
            stop.fail(s + 1, describe(e))
        k = s + 1
        if k == kill_at:
            os.kill(os.getpid(), signal.SIGTERM)
        if failures:
            stop.fail(k, failures[0])
        if stop.due(k) or any(poll(k) for poll in polls):
            ended = stop.poll(k)
            if ended:
                k, failure, interrupted = ended
                break
        for hook in after:
            failure = hook(k, k * dt)
            if failure:
                break
        if failure:
            break
    for ob in observers:
        ob.finish(k, k * dt)
    return failure, k, clock() - t_loop, interrupted


def _seconds(values) -> str:
    return " / ".join(f"{v:.3g}" for v in values) + " s"


def summary(result, output_file) -> list[str]:
    a = result.attrs
    parts = ", ".join(f"{n} {p['steps']} x {p['dt']:.3g} s ({p['wall_time']:.3g} s)"
                      for n, p in result.partitions.items())
    if a.get("analysis") == "static":
        return [f"[solver] {a['scene']}: {a['status']}, static solve at t = {a['t_end']:.6g} s "
                f"on {a['ranks']} rank(s); wall {a['wall_time']:.3g} s (set-up "
                f"{a['setup_wall_time']:.3g} s, solve {a['stepping_wall_time']:.3g} s); peak "
                f"memory per rank {a['peak_rss_mb_per_rank'].max():.0f} MB",
                f"[solver]   output: {output_file}",
                *(f"[solver]   fields: {name}" for name in a.get("field_files", ()))]
    lines = [f"[solver] {a['scene']}: {a['status']}, {a['n_system_steps']} system steps to "
             f"t = {a['t_end']:.6g} s on {a['ranks']} rank(s); wall {a['wall_time']:.3g} s "
             f"(set-up {a['setup_wall_time']:.3g} s, stepping {a['stepping_wall_time']:.3g} s, "
             f"exchange {a['exchange_wall_time']:.3g} s); peak memory per rank "
             f"{a['peak_rss_mb_per_rank'].max():.0f} MB",
             *([f"[solver]   exchange per rank {_seconds(a['exchange_wall_time_per_rank'])}, "
                f"waiting for the other ranks before it {_seconds(a['exchange_wait_time_per_rank'])}"]
               if "exchange_wait_time_per_rank" in a else []),
             f"[solver]   partitions: {parts}"]
    if "vector_rel_error" in a:
        lines.append(f"[solver]   all probes as one vector (Ma et al. 2018 eq. 9, mean over samples): "
                     f"relative error {a['vector_rel_error']:.3e}")
    for name, pr in result.probes.items():
        at = pr["attrs"]
        if at.get("reference_zero"):
            lines.append(f"[solver]   probe {name}: the reference is zero over the run (nothing "
                         f"to be relative to); max |error| {at['max_abs_error']:.3e} "
                         f"(reference: {a['reference']})")
        elif "max_rel_error" in at:
            lines.append(f"[solver]   probe {name}: max relative error {at['max_rel_error']:.3e}, "
                         f"RMS relative error {at['rms_rel_error']:.3e} (reference: {a['reference']})")
        if "stress_peak_error" in at and not np.isfinite(at["stress_peak_error"]):
            lines.append(f"[solver]   probe {name}: the stress wave has not arrived by the end "
                         "of the run (no arrival or peak error)")
        elif "stress_peak_error" in at:
            lines.append(f"[solver]   probe {name}: stress arrival error "
                         f"{100 * at['stress_arrival_error']:+.2f} % of the travel time, peak "
                         f"error {100 * at['stress_peak_error']:+.2f} %")
    lines.append(f"[solver]   output: {output_file}")
    for name in a.get("field_files", ()):
        lines.append(f"[solver]   fields: {name}")
    return lines
