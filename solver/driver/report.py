"""What a run reports: its :class:`RunResult` (root attributes, partitions, probe
histories, energies, broken bonds, heating), gathered on every rank by
:class:`Report` for the checkpoints and the final output
(:mod:`solver.driver.output`)."""
from __future__ import annotations

import resource
import time
from dataclasses import dataclass, field

import numpy as np

from solver.driver.comparison import reference_label


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
            "exchange_wall_time": x_wall, **bond_attrs(part), **level_attrs(part)}
            for part in parts}
        t_axis = np.arange(n_sys + 1) * Dt
        gathered, part_attrs = {}, {}
        for pr, pa in comm.allgather((self.probes.histories(t_axis, done), local_parts)):
            gathered.update(pr)
            for name, attrs in pa.items():       # pieces of one partition on several ranks
                if name in part_attrs:
                    merged = part_attrs[name]
                    merged["ranks"] += 1
                    for key in ("n_owned", "n_external", "bonds_broken", "released_energy",
                                "contact_pairs", "halo_particles"):
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
    """Breakable bonds of a piece: how many broke, the energy they released;
    with contact, the pairs in contact at the end (each counted by one
    piece), the contact search builds and the particles of the piece's halo."""
    force = part.force
    if not force.bonded:
        return {}
    out = {"bonds_broken": len(force.broken), "released_energy": force.released}
    if force.contact is not None:
        out.update(contact_pairs=len(force.contact_pairs()), contact_builds=force.contact.builds,
                   halo_particles=force.n_halo)
    return out


def broken_bonds(parts, comm):
    """Every broken bond of the run, by time (rank 0), or None without breakable bonds."""
    local = [row for p in parts for row in p.force.broken]
    breakable = any(p.force.break_strain is not None for p in parts)
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


def peak_rss_mb() -> float:
    """Peak resident memory of this process so far [MB]: VmHWM of
    /proc/self/status, the high-water mark of this program's own memory.
    getrusage's ru_maxrss only where /proc is missing: Linux carries it
    across exec, so a run started by a large parent (a benchmark, a sweep:
    subprocess vforks) reported the parent's size."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def wait_attrs(clocks, comm) -> dict:
    """``exchange_wait_time_per_rank`` when the run measured it (-exchange_measure_wait)."""
    wait = getattr(clocks, "wait_wall", None)
    waits = comm.allgather(wait)
    if any(w is None for w in waits):
        return {}
    return {"exchange_wait_time_per_rank": np.array(waits)}


def level_attrs(part) -> dict:
    """A levelled partition (partitions: auto): its fine step, level ratios and
    the mass that mass scaling added; nothing for other partitions."""
    levels = getattr(part.spec, "levels", None)
    if levels is None:
        return {}
    out = {"fine_dt": levels.h, "level_ratios": np.array(levels.ratios)}
    if levels.scaling is not None:
        out.update(added_mass=levels.scaling.added, added_mass_fraction=levels.scaling.fraction)
    return out
