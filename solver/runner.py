"""One run of a scene: build partitions, guard, step, exchange, record, report.

On one rank every partition runs in this process; on as many ranks as
partitions, partition p runs on rank p and all of them advance concurrently
within a system step, meeting at the exchange.  Both orders give the same
numbers: partitions only see each other's data through the exchange.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from . import model as model_mod
from . import overlap, reference, stability
from .dem import DemPartition
from .errors import LaunchError, RunFailed, StabilityError
from .exchange import Exchange
from .fem import FemPartition
from .petscutil import Stage, init

PARTITION_TYPES = {"fem": FemPartition, "dem": DemPartition}


@dataclass
class RunResult:
    attrs: dict
    partitions: dict = field(default_factory=dict)
    probes: dict = field(default_factory=dict)
    energy: dict = field(default_factory=dict)

    @property
    def status(self) -> str:
        return self.attrs["status"]


def _silent(*_):
    pass


def check_stability(scene, mdl, layouts, ids):
    """(frequencies, problems) of the explicit partitions ``ids``; numpy only."""
    freqs, problems = {}, []
    for p in ids:
        spec, lay = scene.partitions[p], layouts[p]
        rows, cols, vals = mdl.stiffness_triplets(lay.held)
        fr = stability.omega_max(rows, cols, vals, np.repeat(mdl.mass[lay.held], mdl.dof))
        dt = spec.ratio * scene.time.dt
        freqs[spec.name] = fr
        if scene.guard.stable_step and fr.omega_max * dt >= 2.0:
            problems.append(
                f"partition '{spec.name}': step {dt:.4g} s (ratio {spec.ratio} x time.dt "
                f"{scene.time.dt:.4g} s) is unstable, critical step {fr.critical_step():.4g} s "
                f"(omega_max {fr.omega_max:.4g} rad/s, {fr.method}); reduce time.dt or the ratio")
    return freqs, problems


def run(scene, comm=None, log=print, scene_text: str = "") -> RunResult:
    """Run ``scene`` on ``comm`` (default COMM_WORLD); rank 0 writes the output."""
    from mpi4py import MPI

    from . import output

    t_start = time.perf_counter()
    comm = comm or MPI.COMM_WORLD
    init()
    rank, size = comm.rank, comm.size
    say = log if rank == 0 else _silent
    n_part = len(scene.partitions)
    if size not in (1, n_part):
        raise LaunchError(f"scene '{scene.name}' has {n_part} partitions: run it on 1 or "
                          f"{n_part} ranks, not {size}")
    rank_of = [0] * n_part if size == 1 else list(range(n_part))
    local_ids = [p for p in range(n_part) if rank_of[p] == rank]
    treatment = scene.coupling.external
    R = scene.system_ratio
    n_sys = scene.n_system_steps
    Dt = scene.system_dt

    mdl = model_mod.build(scene)
    layouts = overlap.derive(mdl.neighbours(), scene.partitions,
                             overlap.layer_counts(scene.partitions, treatment))
    freqs, problems = check_stability(scene, mdl, layouts, local_ids)
    problems = sum(comm.allgather(problems), [])
    if problems:
        raise StabilityError(problems[0])

    say(f"[solver] {scene.name}: {n_part} partition(s) on {size} rank(s); system step "
        f"{Dt:.4g} s = {R} x {scene.time.dt:.4g} s, {n_sys} system steps to t = {n_sys * Dt:.6g} s")
    parts = [PARTITION_TYPES[scene.partitions[p].method](
        scene.partitions[p], layouts[p], mdl, MPI.COMM_SELF, treatment, scene.time.dt, R)
        for p in local_ids]
    lines = []
    for part in parts:
        fr = freqs[part.name]
        lines.append(f"[solver]   {part.describe()}")
        lines.append(f"[solver]   {part.name}: built {'; '.join(part.built)}; omega_max "
                     f"{fr.omega_max:.4g} rad/s ({fr.method}), critical step {fr.critical_step():.4g} s")
    for chunk in comm.gather(lines, root=0) or []:
        for line in chunk:
            say(line)

    need_exchange = any(lay.layers for lay in layouts)
    exchange = Exchange(comm, layouts, parts, mdl.dof) if need_exchange else None
    if exchange:
        say(f"[solver]   exchange: VecScatter of (u, v, a) once per system step, external-data "
            f"treatment '{treatment}', scheme '{scene.coupling.scheme}'")
    not_built = ["KSP (all partitions explicit)", "neighbour search (no contacts)"]
    if not exchange:
        not_built.insert(0, "exchange (single partition)")
    say(f"[solver]   not built: {', '.join(not_built)}")

    for part in parts:
        part.initialise(mdl)
    if exchange:
        exchange()

    # probes owned here
    owner = overlap.owner_map(mdl.n_nodes, scene.partitions)
    by_index = {part.layout.index: part for part in parts}
    t_axis = np.arange(n_sys + 1) * Dt
    rec = []
    for probe in scene.probes:
        part = by_index.get(int(owner[probe.node]))
        if part is None:
            continue
        i = part.local_index(probe.node, probe.component)
        rec.append((probe, part.U, part.V, i, np.empty(n_sys + 1), np.empty(n_sys + 1)))
    for _, U, V, i, bu, bv in rec:
        bu[0], bv[0] = U[i], V[i]

    every = scene.output.energy_every if scene.output and scene.output.energy_every else \
        max(1, n_sys // 2000)
    energy = {"t": [], "kinetic": [], "strain": [], "external_work": []}

    def sample(s):
        local = np.zeros(3)
        for part in parts:
            local += part.energies()
        tot = comm.allreduce(local, op=MPI.SUM) if size > 1 else local
        energy["t"].append(s * Dt)
        energy["kinetic"].append(tot[0])
        energy["strain"].append(tot[1])
        energy["external_work"].append(tot[2])
        return tot

    e0 = sample(0)
    E0 = float(e0[0] + e0[1])
    max_work = 0.0
    bound = scene.guard.energy_bound
    failure = None

    stages = {part.name: Stage(part.name) for part in parts}
    stage_x = Stage("exchange")
    x_wall = 0.0
    progress = scene.output.progress if scene.output else 10.0
    clock = time.perf_counter
    t_loop = clock()
    last_report = t_loop
    s = 0
    for s in range(n_sys):
        t0 = s * Dt
        for part in parts:
            st = stages[part.name]
            st.push()
            c0 = clock()
            part.advance(t0)
            part.wall += clock() - c0
            st.pop()
        if exchange:
            stage_x.push()
            c0 = clock()
            exchange()
            x_wall += clock() - c0
            stage_x.pop()
        k = s + 1
        for _, U, V, i, bu, bv in rec:
            bu[k] = U[i]
            bv[k] = V[i]
        if k % every == 0 or k == n_sys:
            kin, strain, work = sample(k)
            total = kin + strain
            max_work = max(max_work, abs(work))
            if not (math.isfinite(total) and math.isfinite(work)):
                failure = f"non-finite state at t = {k * Dt:.6g} s (system step {k})"
            elif total > bound * (E0 + max_work) and total > 1e-300:
                failure = (f"energy grew to {total:.4g} J at t = {k * Dt:.6g} s, above "
                           f"guard.energy_bound {bound:g} x (initial energy {E0:.4g} J + largest "
                           f"|external work| {max_work:.4g} J): the run is unstable")
            if failure:
                break
        if progress and rank == 0 and (k & 255) == 0:
            now = clock()
            if now - last_report >= progress:
                last_report = now
                frac = k / n_sys
                el = now - t_loop
                say(f"[solver] t = {k * Dt:.6g}/{n_sys * Dt:.6g} s ({100 * frac:.0f}%), "
                    f"{el:.1f} s elapsed, about {el * (1 - frac) / frac:.1f} s to go")
    loop_wall = clock() - t_loop
    done = s + 1 if n_sys else 0

    # ---- gather results on every rank (small: probes and attributes)
    local_probes = {probe.name: {"t": t_axis[:done + 1], "displacement": bu[:done + 1],
                                 "velocity": bv[:done + 1],
                                 "attrs": {"node": probe.node, "component": probe.component,
                                           "partition": part_name(scene, owner, probe.node)}}
                    for probe, _, _, _, bu, bv in rec}
    local_parts = {part.name: {
        "method": part.method, "integrator": part.integrator.describe(),
        "ratio": part.spec.ratio, "dt": part.dt, "steps": part.steps, "wall_time": part.wall,
        "n_owned": part.layout.n_owned, "n_external": int(part.layout.external.size),
        "layers": len(part.layout.layers), "boundary": part.layout.boundary,
        "omega_max": freqs[part.name].omega_max,
        "critical_step": freqs[part.name].critical_step(),
        "exchange_wall_time": x_wall} for part in parts}
    probes, part_attrs = {}, {}
    for pr, pa in comm.allgather((local_probes, local_parts)):
        probes.update(pr)
        part_attrs.update(pa)
    probes = {p.name: probes[p.name] for p in scene.probes}
    part_attrs = {p.name: part_attrs[p.name] for p in scene.partitions}

    status = "failed" if failure else "completed"
    attrs = {"scene": scene.name, "status": status, "message": failure or "", "ranks": size,
             "wall_time": clock() - t_start, "stepping_wall_time": loop_wall,
             "exchange_wall_time": max(comm.allgather(x_wall)),
             "scheme": scene.coupling.scheme, "external_treatment": treatment,
             "system_dt": Dt, "base_dt": scene.time.dt, "n_system_steps": done,
             "t_end": done * Dt, "reference": scene.reference, "scene_yaml": scene_text}
    result = RunResult(attrs, part_attrs, probes, {k: np.asarray(v) for k, v in energy.items()})
    result.energy["total"] = result.energy["kinetic"] + result.energy["strain"]
    if scene.reference == "modal" and not failure and probes:
        add_modal_reference(result, mdl, scene)
    for part in parts:
        part.destroy()
    if exchange:
        exchange.destroy()
    if rank == 0:
        output.write(scene.output_file, result)
    comm.barrier()
    if failure:
        raise RunFailed(f"{scene.name}: {failure}; output marked failed: {scene.output_file}")
    return result


def part_name(scene, owner, node) -> str:
    return scene.partitions[int(owner[node])].name


def relative_errors(x, ref):
    """(max |x - ref| / max |ref|, ||x - ref||_2 / ||ref||_2)."""
    err = np.asarray(x) - np.asarray(ref)
    scale_max = np.max(np.abs(ref))
    scale_rms = np.linalg.norm(ref)
    return (float(np.max(np.abs(err)) / scale_max) if scale_max else float(np.max(np.abs(err))),
            float(np.linalg.norm(err) / scale_rms) if scale_rms else float(np.linalg.norm(err)))


def add_modal_reference(result, mdl, scene):
    for probe in scene.probes:
        pr = result.probes[probe.name]
        dof = probe.node * mdl.dof + probe.component
        u_ref, _ = reference.modal(mdl, [dof], pr["t"])
        pr["reference_displacement"] = u_ref[:, 0]
        mx, rms = relative_errors(pr["displacement"], u_ref[:, 0])
        pr["attrs"].update(max_rel_error=mx, rms_rel_error=rms)


def summary(result, output_file) -> list[str]:
    a = result.attrs
    parts = ", ".join(f"{n} {p['steps']} x {p['dt']:.3g} s ({p['wall_time']:.3g} s)"
                      for n, p in result.partitions.items())
    lines = [f"[solver] {a['scene']}: {a['status']}, {a['n_system_steps']} system steps to "
             f"t = {a['t_end']:.6g} s on {a['ranks']} rank(s); wall {a['wall_time']:.3g} s "
             f"(stepping {a['stepping_wall_time']:.3g} s, exchange {a['exchange_wall_time']:.3g} s)",
             f"[solver]   partitions: {parts}"]
    for name, pr in result.probes.items():
        at = pr["attrs"]
        if "max_rel_error" in at:
            lines.append(f"[solver]   probe {name}: max relative error {at['max_rel_error']:.3e}, "
                         f"RMS relative error {at['rms_rel_error']:.3e} (reference: {a['reference']})")
    lines.append(f"[solver]   output: {output_file}")
    return lines
