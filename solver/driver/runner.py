"""One run of a scene: build (:mod:`solver.driver.build`), step, watch, record, report.

What a system step does is the coupling scheme's business
(:mod:`solver.coupling.system_step`, :mod:`solver.coupling.gc`); which rank holds what is
:mod:`solver.partitions.partitioning`'s; what is watched while stepping is
:mod:`solver.driver.monitor`'s; checkpoints are :mod:`solver.driver.state`'s.
"""
from __future__ import annotations

import os
import signal
import time
from dataclasses import dataclass, field

import numpy as np

from solver.model import layout as overlap
from solver.driver.build import build
from solver.driver.comparison import add_reference, check_reference, reference_label
from solver.errors import RunFailed, SceneError, StabilityError
from solver.driver.monitor import EnergyGuard, Probes


@dataclass
class RunResult:
    attrs: dict
    partitions: dict = field(default_factory=dict)
    probes: dict = field(default_factory=dict)
    energy: dict = field(default_factory=dict)
    broken: np.ndarray | None = None     # [n, 6 + dim] t, midpoint, strain, limit, T, i, j
    heat: dict | None = None             # heating series (t, heating_time, max_temperature)

    @property
    def status(self) -> str:
        return self.attrs["status"]


def _silent(*_):
    pass


def run(scene, comm=None, log=print, scene_text: str = "", restart: str | None = None,
        provenance: dict | None = None, overwrite: bool = False,
        check_options: bool = False, kept=None, measure_wait: bool = False) -> RunResult:
    """Run ``scene`` on ``comm`` (default COMM_WORLD); rank 0 writes the output.

    ``restart``: an output file with a checkpoint of this scene; the run goes on
    from there (on any rank count).  ``provenance``: extra root attributes
    (:mod:`solver.driver.provenance`; versions and commit are always written).
    ``overwrite``: a fresh run may replace an output file that holds a
    checkpoint (refused otherwise).  ``check_options``: PETSc options that no
    object of the built run uses are refused before stepping (the command
    line's choice; scripts may set options for other objects of their own).
    ``kept``: the :class:`~solver.model.data.ModelData` the scene was bound with
    (the model build reuses it; None: read afresh).  ``measure_wait``: a barrier
    before every exchange, timing the wait for the slower rank apart
    (``exchange_wait_time_per_rank``; ``-exchange_measure_wait`` on the command line)."""
    from mpi4py import MPI

    from solver.driver import output
    from solver.driver import state

    t_start = time.perf_counter()
    comm = comm or MPI.COMM_WORLD
    rank = comm.rank
    say = log if rank == 0 else _silent
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
    asm = build(scene, comm, say, kept, measure_wait)
    mdl, parts, scheme = asm.model, asm.parts, asm.scheme
    n_sys, Dt = scene.n_system_steps, scene.system_dt

    owner = overlap.owner_map(mdl.n_nodes, scene.partitions)
    from solver.driver import stress
    probes = Probes(scene.probes, parts, owner, n_sys, getattr(mdl, "points", None),
                    stress.build(scene, mdl, parts))
    for probe in scene.probes:
        if probe.at is not None:
            xyz = np.asarray(mdl.points[probe.node], dtype=float)
            gap = np.linalg.norm(xyz - np.asarray(probe.at, dtype=float)[:xyz.size])
            say(f"[solver]   probe {probe.name}: at {list(probe.at)} -> node {probe.node} at "
                f"{[float(f'{c:.6g}') for c in xyz]} ({gap:.3g} m away)")
    heating = None
    if getattr(mdl, "heat", None) is not None:
        from solver.driver.heating import Heating
        heating = Heating(mdl.heat, parts, scene)
        say(f"[solver]   {heating.describe()}")
        if probes.stress is not None:
            probes.stress.heating = heating
    every = energy_every(scene)
    guard = EnergyGuard(parts, comm, Dt, every, scene.guard.energy_bound,
                        scene.guard.max_displacement or body_size(mdl, comm))
    start = 0
    if saved:
        start = saved["step"]
        state.restore(saved, parts, scheme, guard)
        probes.restore(saved["probes"], start)
        if heating is not None and saved.get("heat") is not None:
            heating.restore(saved["heat"])
        say(f"[solver] restarted from {restart} at system step {start} (t = {start * Dt:.6g} s)")
    from solver.driver import provenance as prov
    report = Report(scene, asm, probes, guard, comm, scene_text, t_start, heating)
    report.extra = {"versions": prov.versions(), "commit": prov.commit(), **model_counts(mdl, comm),
                    **(provenance or {})}
    if check_options:
        from solver.petscutil import check_unused
        check_unused(comm, [p.name for p in scene.partitions])
    report.setup_wall = time.perf_counter() - t_start
    from solver.driver.stop import Stopper
    # from the first write on, an interrupt is a flag the step loop polls (the
    # output is kept); a second one stops at once
    with Stopper(comm, start) as stop:
        return _stepped(scene, comm, say, asm, probes, guard, heating, report, stop, start)


def _stepped(scene, comm, say, asm, probes, guard, heating, report, stop, start):
    """The run from its first output on: checkpoint, fields, stepping, the final output."""
    from solver.driver import output
    rank, mdl, parts, scheme = comm.rank, asm.model, asm.parts, asm.scheme
    Dt = scene.system_dt
    spec = scene.output.checkpoint if scene.output else None
    checkpoint = Checkpoint(spec.every, scene, parts, guard, comm, report) if spec else None
    if checkpoint:
        checkpoint(start, 0.0)

    fields = None
    if scene.output and scene.output.fields:
        from solver.driver.fields import FieldWriter
        fields = FieldWriter(scene, mdl, parts, comm, tag=f"_restart{start}" if start else "",
                             heating=heating)
        fields.write(start * Dt)
    stop.where = "stepping"
    try:
        failure, done, loop_wall, interrupted = step_loop(
            scene, scheme, probes, guard, say if rank == 0 else None, comm, stop, fields, start,
            checkpoint, heating)
        if fields:                  # the last frame is the state the run ended in
            fields.write_final(done * Dt)
    finally:
        if fields:
            fields.close()
        if heating:
            heating.destroy()
        probes.destroy()
    stop.where = "while writing the output"

    result = report.result(done, "failed" if failure else "completed", failure or "", loop_wall)
    if fields and rank == 0:
        written = fields.written()
        if result.broken is not None and len(result.broken):
            from solver.driver.fields import write_cracks
            written += write_cracks(scene.output_file, result.broken, mdl.dof)
        result.attrs["field_files"] = np.array(written, dtype=object)
    if scene.reference != "none" and not failure and result.probes:
        add_reference(result, mdl, scene, comm, say)
    # a completed run keeps its final state (restart with a later time.end to go on);
    # a failed one keeps its last good checkpoint
    final = checkpoint.final(done, failure) if checkpoint else None
    asm.destroy()
    if rank == 0:
        from solver.driver.state import group_writer
        output.write(scene.output_file, result, checkpoint=group_writer(final))
    comm.barrier()
    from solver.driver.stop import Interrupted
    if failure:
        raise (Interrupted if interrupted else RunFailed)(
            f"{scene.name}: {failure}; output marked failed: {scene.output_file}")
    late = stop.signals()
    if late:
        raise Interrupted(f"{scene.name}: interrupted ({late}) after the last system step, "
                          f"while writing the output; the output is complete: {scene.output_file}")
    return result


class Checkpoint:
    """Writes the output file with the run state (:mod:`solver.driver.state`) every
    ``every`` system steps, status running, atomically."""

    def __init__(self, every, scene, parts, guard, comm, report):
        from solver.driver.state import fingerprint
        self.every, self.scene, self.parts, self.guard = every, scene, parts, guard
        self.comm, self.report = comm, report
        self.meta = {"fingerprint": fingerprint(scene), "scene": scene.name}

    def __call__(self, k: int, wall: float):
        from solver.driver import output
        from solver.driver import state
        data = state.collect(k, self.parts, self.guard, self.comm, self.report.asm.scheme)
        result = self.report.result(k, "running", "", wall)
        if self.comm.rank == 0:
            self.last = (data, self.meta)
            output.write(self.scene.output_file, result, checkpoint=state.group_writer(self.last))

    def final(self, done: int, failure):
        """What the final file keeps: the state at ``done`` (collective), or after
        a failure the last checkpoint written (rank 0; None elsewhere)."""
        from solver.driver.state import collect
        if failure:
            return getattr(self, "last", None)
        data = collect(done, self.parts, self.guard, self.comm, self.report.asm.scheme)
        return (data, self.meta) if data is not None else None


def peak_rss_mb() -> float:
    """Peak resident memory of this process so far [MB]."""
    import resource
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def energy_every(scene) -> int:
    """System steps between energy samples: output.energy_every, or at least 100
    samples per run, at most one per 10 system steps once a run has 1000 of
    them, and at most ~2000 samples (a sample costs a MatMult per partition)."""
    if scene.output and scene.output.energy_every:
        return scene.output.energy_every
    n = scene.n_system_steps
    return max(1, n // 2000, min(10, n // 100))


class Report:
    """The run's results so far (probes, energies, partition attributes),
    gathered on every rank: for checkpoints and the final output."""

    def __init__(self, scene, asm, probes, guard, comm, scene_text, t_start, heating=None):
        self.scene, self.asm, self.probes, self.guard = scene, asm, probes, guard
        self.heating = heating
        self.comm, self.scene_text, self.t_start = comm, scene_text, t_start
        self.extra = {}

    def result(self, done: int, status: str, message: str, loop_wall: float) -> RunResult:
        scene, comm, parts = self.scene, self.comm, self.asm.parts
        freqs = self.asm.freqs
        n_sys, Dt = scene.n_system_steps, scene.system_dt
        x_wall = self.asm.scheme.clocks.exchange_wall
        local_parts = {part.name: {
            "method": part.method, "integrator": part.integrator.describe(),
            "ratio": part.spec.ratio, "dt": part.dt, "steps": part.steps, "wall_time": part.wall,
            "n_owned": part.layout.n_owned, "n_external": int(part.layout.external.size),
            "layers": len(part.layout.layers), "boundary": part.layout.boundary,
            "omega_max": freqs[part.name][0].omega_max,
            "critical_step": freqs[part.name][1],
            "exchange_wall_time": x_wall, **bond_attrs(part)} for part in parts}
        t_axis = np.arange(n_sys + 1) * Dt
        gathered, part_attrs = {}, {}
        for pr, pa in comm.allgather((self.probes.histories(t_axis, done), local_parts)):
            gathered.update(pr)
            for name, attrs in pa.items():       # pieces of one partition on several ranks
                if name in part_attrs:
                    merged = part_attrs[name]
                    merged["ranks"] += 1
                    for key in ("n_owned", "n_external", "bonds_broken", "released_energy"):
                        if key in merged:
                            merged[key] += attrs[key]
                    merged["boundary"] = np.sort(np.concatenate([merged["boundary"],
                                                                 attrs["boundary"]]))
                    for key in ("wall_time", "exchange_wall_time"):
                        merged[key] = max(merged[key], attrs[key])
                else:
                    part_attrs[name] = {**attrs, "ranks": 1}
        histories = {p.name: gathered[p.name] for p in scene.probes}
        part_attrs = {p.name: part_attrs[p.name] for p in scene.partitions}
        attrs = {"scene": scene.name, "status": status, "message": message, "ranks": comm.size,
                 "wall_time": time.perf_counter() - self.t_start, "stepping_wall_time": loop_wall,
                 "setup_wall_time": self.setup_wall,
                 "peak_rss_mb_per_rank": np.array(comm.allgather(peak_rss_mb())),
                 "exchange_wall_time": max(comm.allgather(x_wall)),
                 "exchange_wall_time_per_rank": np.array(comm.allgather(x_wall)),
                 **wait_attrs(self.asm.scheme.clocks, comm),
                 "scheme": scene.coupling.scheme, "external_treatment": scene.coupling.external,
                 "system_dt": Dt, "base_dt": scene.time.dt, "n_system_steps": done,
                 "t_end": done * Dt, "reference": reference_label(scene),
                 "scene_yaml": self.scene_text, **self.extra}
        for name, pa in part_attrs.items():
            attrs[f"steps_{name}"] = pa["steps"]
            attrs[f"wall_time_{name}"] = pa["wall_time"]
        if self.heating is not None:
            attrs["heating_time_scale"] = self.heating.scale
        return RunResult(attrs, part_attrs, histories, self.guard.arrays(), broken_bonds(parts, comm),
                         self.heating.arrays() if self.heating is not None else None)


def bond_attrs(part) -> dict:
    """Breakable bonds of a piece: how many broke, the energy they released."""
    force = part.force
    if not hasattr(force, "broken"):
        return {}
    return {"bonds_broken": len(force.broken), "released_energy": force.released}


def broken_bonds(parts, comm):
    """Every broken bond of the run, by time (rank 0), or None without breakable bonds."""
    local = [row for p in parts for row in getattr(p.force, "broken", [])]
    breakable = any(getattr(p.force, "break_strain", None) is not None for p in parts)
    if comm.size > 1:
        chunks = comm.gather((breakable, local), root=0)
        if comm.rank != 0:
            return None
        breakable = any(b for b, _ in chunks)
        local = [row for _, rows in chunks for row in rows]
    if not breakable:
        return None
    rows = np.array(sorted(local), dtype=float)
    return rows if rows.size else np.zeros((0, 0))


def body_size(mdl, comm) -> float | None:
    """The largest extent of a continuum's nodes (the lost-particle bound), or None."""
    size = None
    if comm.rank == 0 and hasattr(mdl, "points"):
        size = float(np.ptp(mdl.points, axis=0).max())
    return comm.bcast(size) if comm.size > 1 else size


def model_counts(mdl, comm) -> dict:
    """FE cells and DEM particles of a continuum model (rank 0 holds it whole)."""
    counts = {}
    if comm.rank == 0 and hasattr(mdl, "cells"):
        counts["fe_cells"] = sum(len(conn) for _, conn, _ in mdl.cells)
        zone = mdl.zone
        if zone is not None:
            counts["particles"] = zone.n_core + len(zone.band_points)
            counts["band_particles"] = len(zone.band_points)
    return comm.bcast(counts) if comm.size > 1 else counts


def step_loop(scene, scheme, probes, guard, say, comm, stop, fields=None, start=0,
              checkpoint=None, heating=None):
    """Advance system steps from ``start`` to the end, the first guard failure,
    a partition's failure or an interrupt on any rank (all ranks stop at the
    same step, :mod:`solver.driver.stop`: ``stop``, the run's Stopper, holds the
    signals and failures); ``checkpoint(k, wall)`` every
    ``checkpoint.every`` system steps.

    Returns (failure message or None, system steps done, stepping wall time,
    interrupted)."""
    from solver.errors import describe
    n_sys, Dt = scene.n_system_steps, scene.system_dt
    progress = (scene.output.progress if scene.output else 10.0) if say else 0.0
    every = guard.every
    ck_every = checkpoint.every if checkpoint else 0
    clock = time.perf_counter
    t_loop = last = clock()
    failure, k, interrupted = None, start, False
    failures = scheme.clocks.failures
    # fault injection for the tests: rank 0 sends itself SIGTERM after this system step
    kill_at = int(os.environ.get("MTS_SIGTERM_AT_STEP", "-1")) if comm.rank == 0 else -1
    for s in range(start, n_sys):
        try:
            if heating is not None:
                heating.update(s)
            scheme.step(s * Dt)
            if heating is not None:
                heating.after_step()
        except Exception as e:              # noqa: BLE001 -- stop together, keep the output
            stop.fail(s + 1, describe(e))
        k = s + 1
        if k == kill_at:
            os.kill(os.getpid(), signal.SIGTERM)
        if failures:
            stop.fail(k, failures[0])
        if stop.due(k) or (ck_every and k % ck_every == 0):
            ended = stop.poll(k)
            if ended:
                k, failure, interrupted = ended
                break
        failure = _step_tail(scene, k, probes, guard, fields, checkpoint, every, ck_every,
                             t_loop)
        if failure:
            break
        if progress and (k & 255) == 0 and clock() - last >= progress:
            last = clock()
            frac, el = (k - start) / (n_sys - start), last - t_loop
            say(f"[solver] t = {k * Dt:.6g}/{n_sys * Dt:.6g} s ({100 * k / n_sys:.0f}%), "
                f"{el:.1f} s elapsed, about {el * (1 - frac) / frac:.1f} s to go; "
                f"{guard.latest()}")
    return failure, k, clock() - t_loop, interrupted


def _step_tail(scene, k, probes, guard, fields, checkpoint, every, ck_every, t_loop):
    """After system step ``k``: record probes, write fields, check the guard,
    write a checkpoint; a guard failure message or None."""
    n_sys, Dt = scene.n_system_steps, scene.system_dt
    probes.record(k)
    if fields and k % fields.every == 0:
        fields.write(k * Dt)
    if k % every == 0 or k == n_sys:
        failure = guard.check(k)
        if failure:
            return failure
    if ck_every and k % ck_every == 0 and k < n_sys:
        checkpoint(k, time.perf_counter() - t_loop)
    return None


def wait_attrs(clocks, comm) -> dict:
    """``exchange_wait_time_per_rank`` when the run measured it (-exchange_measure_wait)."""
    wait = getattr(clocks, "wait_wall", None)
    waits = comm.allgather(wait)
    if any(w is None for w in waits):
        return {}
    return {"exchange_wait_time_per_rank": np.array(waits)}


def _seconds(values) -> str:
    return " / ".join(f"{v:.3g}" for v in values) + " s"


def summary(result, output_file) -> list[str]:
    a = result.attrs
    parts = ", ".join(f"{n} {p['steps']} x {p['dt']:.3g} s ({p['wall_time']:.3g} s)"
                      for n, p in result.partitions.items())
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
