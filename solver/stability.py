"""Highest natural frequency of a partition and the explicit step guard.

Explicit Newmark (any beta) and velocity Verlet are stable for
``omega_max * dt < 2``.  For up to ``DENSE_LIMIT`` DOFs the frequency is the
exact largest eigenvalue of M^-1/2 K M^-1/2 (dense symmetric solve); beyond
that it is the Gershgorin bound on the same matrix taken over the element
blocks (sum of |entries| of every block, never formed), which is never below
the true value, so the guard stays on the safe side.  The operator is the one
the partition steps: its cells (fem) or its bonds and overlap cells (dem).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

DENSE_LIMIT = 3000


@dataclass(frozen=True)
class Frequency:
    omega_max: float     # rad/s
    method: str          # "exact" or "Gershgorin bound"

    def critical_step(self, omega_h: float = 2.0) -> float:
        """Largest stable step for an integrator whose limit is ``omega_h``."""
        return omega_h / self.omega_max if self.omega_max > 0 else float("inf")


def omega_max(block_sets, held, mass: np.ndarray, dof: int) -> Frequency:
    """Largest omega of K x = omega^2 M x for the element ``block_sets`` (global
    node ids) over ``held`` nodes and lumped ``mass`` per held DOF."""
    from .assembly import gershgorin, triplets
    n = mass.size
    if n == 0 or not any(len(c) for c, _ in block_sets):
        return Frequency(0.0, "exact")
    if n <= DENSE_LIMIT:
        local = np.full(int(held.max()) + 1, -1, dtype=np.int64)
        local[held] = np.arange(held.size)
        rows, cols, vals = triplets([(local[c], k) for c, k in block_sets], dof)
        s = 1.0 / np.sqrt(mass)      # fixed DOFs carry infinite mass: their rows drop out
        A = np.zeros((n, n))
        np.add.at(A, (rows, cols), vals * s[rows] * s[cols])
        lam = float(np.linalg.eigvalsh(A)[-1])
        return Frequency(float(np.sqrt(max(lam, 0.0))), "exact")
    return Frequency(float(np.sqrt(gershgorin(block_sets, held, mass, dof))), "Gershgorin bound")


def check(scene, spec, model, held):
    """Stability of partition ``spec`` holding ``held`` nodes of ``model``:
    (Frequency, critical step [s], problem message or None).  The limit is the
    integrator's (2 for explicit Newmark and Verlet, none for implicit average
    acceleration), lowered by Rayleigh damping for explicit ones to
    2 (sqrt(1 + xi^2) - xi) with xi the damping ratio at omega_max."""
    from . import integrators
    # what the partition steps: cells for fem, bonds (and overlap cells) for dem
    blocks = model.bond_blocks(held) if spec.method == "dem" else model.stiffness_blocks(held)
    dofs = (held[:, None] * model.dof + np.arange(model.dof)).ravel()
    mass = np.where(model.fixed[dofs], np.inf, np.repeat(model.mass[held], model.dof))
    fr = omega_max(blocks, held, mass, model.dof)
    limit = integrators.make(spec).critical_omega_h()
    if scene.damping.active and spec.integrator != "implicit":
        xi = scene.damping.ratio(fr.omega_max)
        limit = 2.0 * (np.sqrt(1.0 + xi * xi) - xi)
    crit = fr.critical_step(limit)
    dt = spec.ratio * scene.time.dt
    problem = None
    if fr.omega_max * dt >= limit:
        problem = (f"partition '{spec.name}': step {dt:.4g} s (ratio {spec.ratio} x time.dt "
                   f"{scene.time.dt:.4g} s) is unstable, critical step {crit:.4g} s "
                   f"(omega_max {fr.omega_max:.4g} rad/s, {fr.method}); reduce time.dt or the ratio")
    return fr, crit, problem
