"""What a run watches while it steps: probe histories and the energy guard.

``Probes`` records displacement and velocity of the probed DOFs owned on this
rank after every system step.  ``EnergyGuard`` samples kinetic energy, strain
energy and external work (summed over ranks) every ``every`` system steps and
reports a failure when the total is not finite or exceeds ``bound`` x (initial
energy + largest |external work| so far): an energy-consistent run never does,
an unstable one does within a few samples.  External work is the discrete
W = sum 1/2 (f_n + f_n+1) . (u_n+1 - u_n), which the trapezoidal rule (Newmark
average acceleration) balances exactly.  ``dissipated`` is what Rayleigh
damping (and contact dashpots) took, sum h v.C v per step at the velocity the
residual uses, in every damped partition of every scheme: kinetic + strain +
dissipated (+ released by broken bonds) = initial energy + external work.
"""
from __future__ import annotations

import math

import numpy as np

from solver.driver.observers import Observer


class Probes(Observer):
    def __init__(self, probes, parts, owner, n_steps: int, points=None, stress=None):
        """``parts``: this rank's partition pieces; a probe is recorded by the
        piece that owns its node (on exactly one rank).  ``points``: node
        coordinates (continua), written with the histories.  ``stress``: a
        :class:`solver.driver.stress.StressProbes` (continua), whose sigma_cc
        histories are recorded too."""
        self._rec = []
        self.points = points
        self.stress = stress
        self._sigma = {p.name: np.empty(n_steps + 1) for p in probes} if stress else {}
        for probe in probes:
            part = next((p for p in parts if p.layout.index == owner[probe.node] and
                         0 <= p.layout.local(np.array([probe.node]))[0] < p.layout.n_owned), None)
            if part is None:
                continue
            i = part.local_index(probe.node, probe.component)
            self._rec.append((probe, part, part.U, part.V, i,
                              np.empty(n_steps + 1), np.empty(n_steps + 1)))
        self.record(0)

    def restore(self, saved: dict, k: int):
        """Histories of a checkpoint up to system step ``k`` (name -> (u, v[, sigma]))."""
        for probe, _, _, _, _, bu, bv in self._rec:
            u, v, *sigma = saved[probe.name]
            bu[:k + 1] = u[:k + 1]
            bv[:k + 1] = v[:k + 1]
            if sigma and probe.name in self._sigma:
                self._sigma[probe.name][:k + 1] = sigma[0][:k + 1]
            elif probe.name in self._sigma:      # a file without it (shells before 2026-12)
                self._sigma[probe.name][:k + 1] = np.nan

    def after_step(self, step: int, t: float) -> None:
        """Observer hook: record every system step."""
        self.record(step)

    def record(self, k: int):
        for _, _, U, V, i, bu, bv in self._rec:
            bu[k] = U[i]
            bv[k] = V[i]
        if self.stress is not None:
            for name, value in self.stress.values().items():
                self._sigma[name][k] = value

    def destroy(self):
        """Free the stress probes' PETSc objects (their operators live on the
        partitions' communicators: left to the garbage collector they outlive
        PetscFinalize, and MPICH reports their datatypes as leaked)."""
        if self.stress is not None:
            self.stress.destroy()

    def histories(self, t_axis, done: int) -> dict:
        """This rank's probes up to system step ``done``."""
        out = {}
        for probe, part, _, _, _, bu, bv in self._rec:
            out[probe.name] = {"t": t_axis[:done + 1], "displacement": bu[:done + 1],
                               "velocity": bv[:done + 1], "attrs": self._attrs(probe, part)}
            if probe.name in self._sigma:
                out[probe.name]["stress"] = self._sigma[probe.name][:done + 1]
        return out

    def _attrs(self, probe, part) -> dict:
        attrs = {"node": probe.node, "component": probe.component, "partition": part.name}
        if self.stress is not None and not self.stress.has_stress(probe.name):
            attrs["stress"] = ("none (NaN): a rotation component at a node of no shell cell "
                               "has no stress component")
        elif self.stress is not None and self.stress.is_shell(probe.name):
            attrs["stress"] = ("von Mises [Pa] of the larger face (N / t -+ 6 M / t^2), "
                               "average of the node's shell cells")
        elif self.stress is not None:
            axis = "xyz"[probe.component]
            attrs["stress"] = (f"sigma_{axis}{axis} [Pa]: " +
                               ("bond (virial) stress" if part.method == "dem" else
                                "average of the node's FE cell stresses"))
        if self.points is not None:
            xyz = np.asarray(self.points[probe.node], dtype=float)
            attrs["coordinates"] = xyz                 # where the probe records
            if probe.at is not None:                   # snapped from the point asked for
                attrs["at"] = np.asarray(probe.at, dtype=float)[:xyz.size]
                attrs["snap_distance"] = float(np.linalg.norm(xyz - attrs["at"]))
        return attrs


class EnergyGuard(Observer):
    def __init__(self, parts, comm, dt_system: float, every: int, bound: float,
                 max_displacement: float | None = None, space: int | None = None):
        self.parts = parts
        self.max_displacement = max_displacement
        self.space = space              # the translations among a node's DOFs (None: all)
        self.comm = comm
        self.dt = dt_system
        self.every = every
        self.bound = bound
        self.series = {"t": [], "kinetic": [], "strain": [], "external_work": [],
                       "dissipated": []}
        kin, strain, _, _ = self._sample(0)
        self.initial = kin + strain
        self.max_work = 0.0

    def _sample(self, k):
        local = np.zeros(4)
        for part in self.parts:
            local += part.energies()
        if self.comm.size > 1:
            # lazy: importing mpi4py starts MPI; the entry point decides when
            from mpi4py import MPI
            local = self.comm.allreduce(local, op=MPI.SUM)
        for name, value in zip(("kinetic", "strain", "external_work", "dissipated"), local):
            self.series.setdefault(name, []).append(value)
        self.series["t"].append(k * self.dt)
        return local

    def start(self, first: int, last: int) -> None:
        self.last = last

    def after_step(self, step: int, t: float) -> str | None:
        """Observer hook: a sample every ``every`` system steps and at the last one."""
        if step % self.every == 0 or step == self.last:
            return self.check(step)
        return None

    def check(self, k: int) -> str | None:
        """Sample at system step ``k``; a failure message, or None."""
        kin, strain, work, _ = self._sample(k)
        total = kin + strain
        self.max_work = max(self.max_work, abs(work))
        t = k * self.dt
        if not (math.isfinite(total) and math.isfinite(work)):
            return f"non-finite state at t = {t:.6g} s (system step {k})"
        lost = self._lost() if self.max_displacement else None
        if lost:
            return f"{lost} at t = {t:.6g} s (system step {k})"
        scale = self.initial + self.max_work
        # no scale yet (at rest, no work done): a linear system cannot blow up from there
        if scale > 0 and total > self.bound * scale:
            return (f"energy grew to {total:.4g} J at t = {t:.6g} s, above guard.energy_bound "
                    f"{self.bound:g} x (initial energy {self.initial:.4g} J + largest |external "
                    f"work| {self.max_work:.4g} J): the run is unstable")
        return None

    def _lost(self) -> str | None:
        """The farthest-moved owned node if beyond max_displacement (collective):
        its translation, not its rotations (shells, rotating particles)."""
        far = (0.0, -1, "", "")
        for part in self.parts:
            n = part.n_own
            if not n or part.dof is None:
                continue
            dist = np.linalg.norm(part.U[:n].reshape(-1, part.dof)[:, :self.space], axis=1)
            i = int(np.argmax(dist))
            if dist[i] > far[0]:
                far = (float(dist[i]), int(part.layout.owned[i]), part.name, part.method)
        if self.comm.size > 1:
            far = max(self.comm.allgather(far))
        if far[0] <= self.max_displacement:
            return None
        what = "particle" if far[3] == "dem" else "node"
        return (f"{what} {far[1]} of partition '{far[2]}' moved {far[0]:.3g} m, beyond "
                f"guard.max_displacement {self.max_displacement:.3g} m (lost)")

    def latest(self) -> str:
        """The last sample, as a progress line shows it (no collective)."""
        s = self.series
        kin, strain, work, lost = (s[k][-1] for k in ("kinetic", "strain", "external_work",
                                                      "dissipated"))
        return (f"energies at t = {s['t'][-1]:.4g} s: kinetic {kin:.4g} J, strain {strain:.4g} J, "
                f"work {work:.4g} J, dissipated {lost:.4g} J, balance kinetic + strain + "
                f"dissipated - work {kin + strain + lost - work:.3g} J")

    def memory(self) -> dict:
        """What a checkpoint keeps of the guard."""
        return {"series": {k: list(v) for k, v in self.series.items()},
                "initial": self.initial, "max_work": self.max_work}

    def restore(self, memory: dict):
        self.series = {k: list(v) for k, v in memory["series"].items()}
        self.initial = memory["initial"]
        self.max_work = memory["max_work"]

    def arrays(self) -> dict:
        out = {k: np.asarray(v) for k, v in self.series.items()}
        out["total"] = out["kinetic"] + out["strain"]
        return out
