"""Highest natural frequency of a partition and the explicit step guard.

Explicit Newmark (any beta) and velocity Verlet are stable for
``omega_max * dt < 2``.  For up to ``EXACT_LIMIT`` DOFs the frequency is the
exact largest eigenvalue of M^-1/2 K M^-1/2 (dense symmetric solve); up to
``LANCZOS_LIMIT`` it is a Lanczos estimate of the same eigenvalue (ARPACK through
scipy on the sparse matrix, converged to ``LANCZOS_TOL`` and raised by
``LANCZOS_MARGIN``: 25 ms instead of 2.5 s at 3000 DOF), both known before any
PETSc object exists;
beyond that it is the Gershgorin bound of the
same matrix, taken from the partition's assembled operator (still before
stepping), which is never below the true value, so the guard stays on the
safe side.  The operator is the one
the partition steps: its cells (fem) or its bonds and overlap cells (dem).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from solver.model.arrays import dof_masses

EXACT_LIMIT = 300        # dense eigenvalues up to here
DENSE_LIMIT = 3000       # dense eigenvalues when Lanczos does not converge, up to here
LANCZOS_LIMIT = 300000   # scipy's Lanczos (before PETSc) up to here; assembled Gershgorin above
LANCZOS_TOL = 1e-10      # ARPACK's relative accuracy of the Ritz value
LANCZOS_MARGIN = 1e-6    # the estimate is raised by this fraction, so it is never below


@dataclass(frozen=True)
class Frequency:
    omega_max: float     # rad/s
    method: str          # "exact" or "Gershgorin bound"

    def critical_step(self, omega_h: float = 2.0) -> float:
        """Largest stable step for an integrator whose limit is ``omega_h``."""
        return omega_h / self.omega_max if self.omega_max > 0 else float("inf")


def omega_max(block_sets, held, mass: np.ndarray, dofmap) -> Frequency:
    """Largest omega of K x = omega^2 M x for the element ``block_sets`` (global
    node ids) over ``held`` nodes (DOFs per ``dofmap``, the model's) and lumped
    ``mass`` per held DOF."""
    from solver.model.dofmap import DofMap
    from solver.partitions.assembly import triplets
    n = mass.size
    if n == 0 or not any(len(c) for c, _ in block_sets):
        return Frequency(0.0, "exact")
    if n <= LANCZOS_LIMIT:
        local = np.full(int(held.max()) + 1, -1, dtype=np.int64)
        local[held] = np.arange(held.size)
        rows, cols, vals = triplets([(local[c], k) for c, k in block_sets],
                                    DofMap(dofmap.counts[held]))
        s = 1.0 / np.sqrt(mass)      # fixed DOFs carry infinite mass: their rows drop out
        if n > EXACT_LIMIT:
            lam = _lanczos(rows, cols, vals * s[rows] * s[cols], n)
            if lam is not None:
                return Frequency(float(np.sqrt(max(lam, 0.0)) * (1 + LANCZOS_MARGIN)), "Lanczos")
            if n > DENSE_LIMIT:
                return None          # not converged: the Gershgorin bound of the operator
        A = np.zeros((n, n))
        np.add.at(A, (rows, cols), vals * s[rows] * s[cols])
        lam = float(np.linalg.eigvalsh(A)[-1])
        return Frequency(float(np.sqrt(max(lam, 0.0))), "exact")
    return None                      # larger: from the assembled operator (gershgorin)


def _lanczos(rows, cols, vals, n):
    """Largest eigenvalue of the symmetric COO matrix by ARPACK's Lanczos, or
    None if it does not converge (the caller then solves densely)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.linalg import ArpackNoConvergence, eigsh
    A = coo_matrix((vals, (rows, cols)), shape=(n, n)).tocsr()
    try:
        lam = eigsh(A, k=1, which="LA", tol=LANCZOS_TOL, ncv=min(n - 1, 40),
                    v0=np.random.default_rng(0).standard_normal(n), maxiter=20 * n,
                    return_eigenvectors=False)
    except ArpackNoConvergence:
        return None
    return float(lam[0])


ROWS_PER_CHUNK = 60000      # rows of the operator scaled at a time by gershgorin


def gershgorin(Kneg, mass: np.ndarray, fixed: np.ndarray) -> Frequency:
    """Gershgorin bound of M^-1/2 K M^-1/2 from a partition's assembled operator
    (this rank's rows; collective): max_i sum_j |K_ij| s_i s_j with s = m^-1/2
    and 0 on fixed DOFs, as PETSc's infinity norm of diagonally scaled row
    chunks (MatCreateSubMatrix), so only a chunk is ever copied."""
    from solver.petscutil import init
    P = init()
    comm = Kneg.getComm().tompi4py()
    s = np.where(fixed, 0.0, 1.0 / np.sqrt(mass))
    bs = Kneg.getBlockSize()
    lo, hi = Kneg.getOwnershipRange()
    step = max(bs, ROWS_PER_CHUNK // bs * bs)
    n_chunks = comm.allreduce(-(-(hi - lo) // step), op=_max())
    right = Kneg.createVecRight()
    right.setArray(s)
    cols = P.IS().createStride(hi - lo, lo, 1, comm=Kneg.getComm())
    cols.setBlockSize(bs)
    radius = 0.0
    for c in range(n_chunks):
        a, b = min(lo + c * step, hi), min(lo + (c + 1) * step, hi)
        rows = P.IS().createStride(b - a, a, 1, comm=Kneg.getComm())
        rows.setBlockSize(bs)
        B = Kneg.createSubMatrix(rows, cols)
        left = B.createVecLeft()
        left.setArray(s[a - lo:b - lo])
        try:
            B.diagonalScale(left, right)
        except P.Error:              # a type without diagonal scaling (e.g. dense, SELL)
            B.convert("aij")
            B.diagonalScale(left, right)
        radius = max(radius, B.norm(P.NormType.NORM_INFINITY))
        for obj in (B, left, rows):
            obj.destroy()
    for obj in (right, cols):
        obj.destroy()
    return Frequency(float(np.sqrt(radius)), "Gershgorin bound")


def side(scene, spec, model, held, build, note):
    """A partition built by a scheme that lays out its own sides (gc,
    conserving): the dense check on ``model``'s blocks of ``held``, then
    ``build()``, and for partitions too large for the dense check the bound
    from the assembled operator.  Returns (partition, (Frequency, critical
    step)); an unstable step raises StabilityError, ``note`` appended."""
    from solver.errors import StabilityError
    fr, crit, problem = check(scene, spec, model, held)
    part = None
    if not problem:
        part = build()
        if fr is None:
            fr, crit, problem = assembled(scene, part)
    if problem:
        raise StabilityError(f"{problem} ({note})")
    return part, (fr, crit)


def assembled(scene, part):
    """(Frequency, critical step, problem) of a built partition from its operator."""
    still = part.fixed_dofs
    if coupled_fe(scene, part.spec):                    # the core particles held
        still = still | (np.arange(still.size) >= part.n_own)
    fr = gershgorin(part.Kneg, part.mass, still)
    if part.method == "dem":
        fr = with_contact(fr, part.force_model, np.where(still, np.inf, part.mass))
    return (fr, *verdict(scene, part.spec, fr))


def _max():
    from mpi4py import MPI
    return MPI.MAX


# The transition scheme (seed 003), from the spectral radius of its system-step
# map (docs/transition.md): sub-cycled, it is weakly unstable without damping
# at any step, and stable with a damping ratio >= TRANSITION_XI at the DEM's
# highest frequency up to omega_max * fdt = 1.23-1.62 with the predictor band
# motion (bands of 2-4 particle spacings, ratios 2-8, a 10x stiffer lattice),
# 1.30 linear, 0.70 velocity and 0.23 hold (5-layer band, ratio 4), omega_max
# being the FE partition's own (band masses and carried bonds included, core
# particles held).  Its FE step is kept below TRANSITION_OMEGA_H / omega_max,
# about 6 % under the weakest measured case.
TRANSITION_OMEGA_H = {"predictor": 1.15, "linear": 1.15, "velocity": 0.65, "hold": 0.2}
TRANSITION_XI = 0.01


def coupled_fe(scene, spec) -> bool:
    """Whether ``spec`` is the FE side of a transition scheme."""
    return scene.coupling.scheme == "transition" and spec.method == "fem"


def check(scene, spec, model, held, n_owned=None):
    """Stability of partition ``spec`` holding ``held`` nodes of ``model``:
    (Frequency, critical step [s], problem message or None).  The limit is the
    integrator's (2 for explicit Newmark and Verlet, none for implicit average
    acceleration), lowered by Rayleigh damping for explicit ones to
    2 (sqrt(1 + xi^2) - xi) with xi the damping ratio at omega_max.  External
    nodes count with their masses, except on a transition scheme's FE side,
    whose external particles (the first ``n_owned`` held nodes are its own)
    are held: its limit is at most TRANSITION_OMEGA_H."""
    # what the partition steps: cells for fem, bonds (and overlap cells) for dem
    blocks = model.bond_blocks(held) if spec.method == "dem" else model.stiffness_blocks(held)
    dm = model.dofmap
    still = model.fixed[dm.dofs(held)]
    if coupled_fe(scene, spec) and n_owned is not None:
        still = still | (np.arange(still.size) >= dm.count(held[:n_owned]))
    mass = np.where(still, np.inf, dof_masses(model, held))
    fr = omega_max(blocks, held, mass, dm)
    if fr is None:
        return None, None, None      # decided once the operator exists (verdict)
    if spec.method == "dem":
        fr = with_contact(fr, model, mass)
    return (fr, *verdict(scene, spec, fr))


def with_contact(fr: Frequency, model, mass) -> Frequency:
    """``fr`` raised for particle contact (model.lattice.contact): lambda_max of
    the bonds plus 2 z k / m_min, z the largest coordination of spheres, k the
    contact stiffness (hertz: its tangent at an overlap of 0.1 r)."""
    contact = getattr(model, "contact", None)
    if contact is None:
        return fr
    from solver.partitions.contact import coordination
    m = np.asarray(mass, dtype=float)
    m = m[np.isfinite(m) & (m > 0)]
    if not m.size:
        return fr
    from solver.partitions.contact import bound_stiffness
    lam = fr.omega_max ** 2 + 2 * coordination(model.dof) * bound_stiffness(contact) / m.min()
    return Frequency(float(np.sqrt(lam)), fr.method + " + contact bound")


def verdict(scene, spec, fr: Frequency):
    """(critical step, problem message or None) of partition ``spec`` at ``fr``."""
    from solver.partitions import integrators
    limit = integrators.make(spec).critical_omega_h()
    if scene.damping.active and spec.integrator != "implicit":
        xi = scene.damping.ratio(fr.omega_max)
        limit = 2.0 * (np.sqrt(1.0 + xi * xi) - xi)
    coupled = coupled_fe(scene, spec)
    if coupled:
        limit = min(limit, TRANSITION_OMEGA_H[scene.coupling.band_motion])
    crit = fr.critical_step(limit)
    dt = spec.ratio * scene.time.dt
    problem = None
    if fr.omega_max * dt >= limit:
        why = (f"; the transition scheme keeps omega_max * fdt < {limit:.3g}" if coupled else "")
        problem = (f"partition '{spec.name}': step {dt:.4g} s (ratio {spec.ratio} x time.dt "
                   f"{scene.time.dt:.4g} s) is unstable, critical step {crit:.4g} s "
                   f"(omega_max {fr.omega_max:.4g} rad/s, {fr.method}{why}); reduce time.dt or "
                   "the ratio")
    return crit, problem


def transition_damping(scene, freqs):
    """The problem with a sub-cycled transition scheme whose stiffness-proportional
    damping gives less than TRANSITION_XI at the dem partition's omega_max, or None."""
    if scene.coupling.scheme != "transition" or scene.system_ratio == 1:
        return None
    dem = next(p for p in scene.partitions if p.method == "dem")
    fr = freqs.get(dem.name, (None,))[0]
    if fr is None or fr.omega_max <= 0:
        return None
    need = 2 * TRANSITION_XI / fr.omega_max
    if scene.damping.beta >= need * (1 - 1e-12):
        return None
    return (f"damping.beta: {scene.damping.beta:g} s: the transition scheme sub-cycles (FE step "
            f"{scene.system_ratio} x the DE step) and needs damping.beta >= {need:.3g} s, a "
            f"damping ratio >= {TRANSITION_XI:g} at the DEM's highest frequency "
            f"{fr.omega_max:.4g} rad/s; without it the sub-cycled coupling is weakly unstable "
            "(docs/transition.md)")
