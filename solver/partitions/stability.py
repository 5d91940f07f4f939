"""Highest natural frequency of a partition and the explicit step guard.

Explicit Newmark (any beta) and velocity Verlet are stable for
``omega_max * dt < 2``.  omega_max^2 is the largest eigenvalue lambda_max of
A = M^-1/2 K M^-1/2 (lumped M: node masses, shell rotary inertias; held DOFs
drop out) for the operator the partition steps: its cells (fem) or its bonds
and overlap cells (dem).

- Up to ``EXACT_LIMIT`` DOFs: the exact eigenvalue (dense symmetric solve).
- Up to ``PREBUILD_LIMIT``: Lanczos (:mod:`solver.model.lanczos`) on the
  sparse matrix on rank 0, before any PETSc object exists, so an unstable
  step is refused before anything is built.
- Above: the same Lanczos on the partition's assembled PETSc operator, right
  after assembly, on all of its ranks (MatMult; the start vector is a
  function of the model DOF ids, so any rank count gives the same value to
  round-off).

The Lanczos estimate is theta / (1 - ``LANCZOS_EPS``) after as many steps as
make theta < (1 - LANCZOS_EPS) lambda_max less likely than
``LANCZOS_FAILURE`` (a proven bound for a random start that holds for any
spectrum; about 210-240 steps from 10^3 to 10^6 DOF), theta the largest
Ritz value, which is never above lambda_max.  So omega_max is about
LANCZOS_EPS / 2 = 0.1 % above the true value (measured:
benchmarks/bench_critical_step.py, docs/benchmarks/bench_critical_step.md), against up
to a third for the Gershgorin bound of A, which caps it (never below the
true value; it is what an estimate is where Lanczos runs into a NaN).

A partition with no free DOF has nothing to step (omega_max 0, no critical
step); an operator with a NaN or infinite entry has no critical step and is
refused (SceneError naming the partition).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from solver.model.arrays import dof_masses
from solver.errors import SceneError, StabilityError
from solver.model import lanczos
from solver.partitions import integrators
from solver.model.dofmap import DofMap
from solver.partitions.assembly import triplets
from solver.memory import release
from solver.petscutil import vec_on, init
from solver.partitions.contact import coordination, bound_stiffness

EXACT_LIMIT = 300        # dense eigenvalues up to here
DENSE_LIMIT = 3000       # dense eigenvalues when Lanczos does not converge, up to here
PREBUILD_LIMIT = 20000   # Lanczos on rank 0 before PETSc up to here; on the PETSc operator above
LANCZOS_EPS = lanczos.EPS          # lambda_max is estimated as theta / (1 - LANCZOS_EPS) ...
LANCZOS_FAILURE = lanczos.FAILURE  # ... after the steps that make it too low less likely than this
NOTHING = "nothing to step"


@dataclass(frozen=True)
class Frequency:
    omega_max: float     # rad/s
    method: str          # "exact", "Lanczos", "Gershgorin bound" or NOTHING

    def critical_step(self, omega_h: float = 2.0) -> float:
        """Largest stable step for an integrator whose limit is ``omega_h``."""
        return omega_h / self.omega_max if self.omega_max > 0 else float("inf")


# a partition of a static analysis (which takes no step): no frequency is estimated
UNCHECKED = Frequency(0.0, "not estimated: analysis static takes no step")


def seconds(*values: float, digits: int = 4) -> list[str]:
    """``values`` [s] with ``digits`` significant digits, more (up to 10) until
    values that differ print differently: a step and its critical step never
    read the same."""
    for d in range(digits, 11):
        out = [f"{v:.{d}g}" for v in values]
        if len({o for o in out}) == len(set(values)):
            break
    return out


def non_finite(name: str):
    return SceneError(f"partition '{name}': M^-1 K has a NaN or infinite entry (a mass or "
                      "stiffness beyond floating point, e.g. a near-zero or non-finite thickness, "
                      "E or density), so it has no critical step; check the material and the "
                      "cell sizes")


def scales(mass, still, diag, name) -> np.ndarray:
    """M^-1/2 on the free DOFs, 0 on the held ones (and on massless DOFs
    without stiffness, which nothing moves); a free DOF that has stiffness but
    no positive finite mass is refused."""
    free = ~np.asarray(still, bool)
    good = np.isfinite(mass) & (mass > 0)
    if np.any(free & ~good & (diag != 0)) or not np.all(np.isfinite(diag[free])):
        raise non_finite(name)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(free & good, 1.0 / np.sqrt(np.where(good, mass, 1.0)), 0.0)


def estimate(scaled, x0, n_free: int, ger: float, comm, name: str) -> Frequency:
    """omega_max from Lanczos on ``scaled(ger)``, a function applying A / ger
    (eigenvalues in [0, 1]: no overflow for any finite operator), ``ger`` the
    Gershgorin bound of lambda_max, which caps the estimate; ``n_free`` free
    DOFs in all, start rows ``x0``."""
    if not np.isfinite(ger):
        raise non_finite(name)
    if ger == 0.0:
        return Frequency(0.0, "Gershgorin bound")            # no stiffness at all
    k = lanczos.steps(n_free, LANCZOS_EPS, LANCZOS_FAILURE)
    with np.errstate(all="ignore"):
        theta, done = lanczos.largest(scaled(ger), x0, min(k, n_free), comm)
    if not np.isfinite(theta):
        raise non_finite(name)
    theta *= ger
    lam = theta if done < k else theta / (1 - LANCZOS_EPS)    # fewer: the Krylov space is all
    if lam >= ger:
        return Frequency(float(np.sqrt(ger)), "Gershgorin bound")
    return Frequency(float(np.sqrt(max(lam, 0.0))), "Lanczos")


def omega_max(block_sets, held, mass: np.ndarray, dofmap, name: str = "?") -> Frequency | None:
    """Largest omega of K x = omega^2 M x for the element ``block_sets`` (global
    node ids) over ``held`` nodes (DOFs per ``dofmap``, the model's) and lumped
    ``mass`` per held DOF (inf: held still); None above PREBUILD_LIMIT DOFs
    (then :func:`assembled` decides once the operator exists)."""
    from scipy.sparse import coo_matrix  # lazy: scipy loads only where it is used

    n = mass.size
    still = np.isinf(mass) & (mass > 0)
    if n == 0 or still.all() or not any(len(c) for c, _ in block_sets):
        return Frequency(0.0, NOTHING)
    if n > PREBUILD_LIMIT:
        return None
    local = np.full(int(held.max()) + 1, -1, dtype=np.int64)
    local[held] = np.arange(held.size)
    rows, cols, vals = triplets([(local[c], k) for c, k in block_sets],
                                DofMap(dofmap.counts[held]))
    with np.errstate(all="ignore"):
        diag = np.bincount(rows[rows == cols], weights=vals[rows == cols], minlength=n)
        s = scales(mass, still, diag, name)
        vals = vals * s[rows] * s[cols]
    if not np.all(np.isfinite(vals)):
        raise non_finite(name)
    if not s.any():
        return Frequency(0.0, NOTHING)
    A = coo_matrix((vals, (rows, cols)), shape=(n, n)).tocsr()
    n_free = int(np.count_nonzero(s))
    if n > EXACT_LIMIT and n_free > EXACT_LIMIT:
        ger = float(abs(A).sum(axis=1).max())
        return estimate(lambda g: (A / g).dot, lanczos.start(dofmap.dofs(held)) * (s > 0),
                        n_free, ger, None, name)
    free = np.flatnonzero(s)
    lam = float(np.linalg.eigvalsh(A[free][:, free].toarray())[-1])
    return Frequency(float(np.sqrt(max(lam, 0.0))), "exact")


def from_operator(Kneg, mass: np.ndarray, still: np.ndarray, ids: np.ndarray,
                  name: str) -> Frequency:
    """omega_max from a partition's assembled operator ``Kneg`` (= -K; this
    rank's rows, model DOF ids ``ids``; collective): Lanczos with MatMult."""
    comm = Kneg.getComm().tompi4py()
    diag = -Kneg.getDiagonal().getArray()
    error = None
    try:
        s = scales(mass, still, diag, name)
    except Exception as e:           # noqa: BLE001 -- every rank learns it, then raises
        error, s = e, np.zeros(mass.size)
    del diag
    errors = [e for e in comm.allgather(error) if e is not None]
    if errors:
        raise errors[0]
    if not comm.allreduce(bool(s.any()), op=_or()):
        return Frequency(0.0, NOTHING)
    n_free = comm.allreduce(int(np.count_nonzero(s)))
    ger = gershgorin(Kneg, mass, s == 0).omega_max ** 2
    release()                        # the row chunks' copies, before the Lanczos vectors
    x, y = np.zeros(mass.size), np.zeros(mass.size)
    X, Y = vec_on(x, Kneg.getComm()), vec_on(y, Kneg.getComm())

    def scaled(g):
        t = -s / g

        def apply(q):            # s K s q / g = -(s / g) Kneg (s q)
            np.multiply(s, q, out=x)
            Kneg.mult(X, Y)
            return t * y
        return apply
    try:
        return estimate(scaled, lanczos.start(ids) * (s > 0), n_free, ger, comm, name)
    finally:
        X.destroy()
        Y.destroy()


def _or():
    from mpi4py import MPI  # lazy: importing mpi4py starts MPI; the entry point decides when
    return MPI.LOR


ROWS_PER_CHUNK = 30000      # rows of the operator scaled at a time by gershgorin (a chunk of
#   60,000 rows of a lattice was 70 MB, the peak of a dem rank of the 2.27 M-DOF bar; each
#   chunk costs a pass over the columns: 12,000 took 2.5 x as long)


def gershgorin(Kneg, mass: np.ndarray, fixed: np.ndarray) -> Frequency:
    """Gershgorin bound of M^-1/2 K M^-1/2 from a partition's assembled operator
    (this rank's rows; collective): max_i sum_j |K_ij| s_i s_j with s = m^-1/2
    and 0 on fixed DOFs, as PETSc's infinity norm of diagonally scaled row
    chunks (MatCreateSubMatrix), so only a chunk is ever copied."""
    P = init()
    comm = Kneg.getComm().tompi4py()
    with np.errstate(divide="ignore"):
        s = np.where(fixed | ~(mass > 0), 0.0, 1.0 / np.sqrt(np.where(mass > 0, mass, 1.0)))
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
    ``build()``, and for partitions too large for the check before building
    the estimate from the assembled operator.  Returns (partition, (Frequency, critical
    step)); an unstable step raises StabilityError, ``note`` appended."""
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
    fr = from_operator(part.Kneg, part.mass, still, part.held_dofs, part.name)
    if part.method == "dem":
        fr = with_contact(fr, part.force_model, np.where(still, np.inf, part.mass))
    return (fr, *verdict(scene, part.spec, fr))


def _max():
    from mpi4py import MPI  # lazy: importing mpi4py starts MPI; the entry point decides when
    return MPI.MAX


# The transition scheme (Zhang et al. 2009; its rule: solver/coupling/transition_zone.py),
# from the spectral radius of its system-step
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
    """Whether the coupling scheme holds partition ``spec``'s external nodes
    still in its stability check (the FE side of a transition scheme)."""
    return scene.scheme.holds_externals(scene, spec)


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
    fr = omega_max(blocks, held, mass, dm, spec.name)
    if fr is None:
        return None, None, None      # decided once the operator exists (verdict)
    if spec.method == "dem":
        fr = with_contact(fr, model, mass)
    return (fr, *verdict(scene, spec, fr))


def with_contact(fr: Frequency, model, mass) -> Frequency:
    """``fr`` raised for particle contact (model.lattice.contact): lambda_max of
    the bonds plus 2 z k / m_min, z the largest coordination of spheres, k the
    contact stiffness (hertz: its tangent at an overlap of 0.1 r; rotating
    particles: their shear springs' stiffness x (1 + r^2 m / I), the most for
    any particle); ``mass``: the held DOFs' masses (inf: held still)."""
    contact = model.contact
    if contact is None:
        return fr
    space = model.points.shape[1]
    m = np.asarray(mass, dtype=float)
    spin = 0.0
    if model.rotary is not None:          # rotating particles: (x, y, theta) per node
        m = m.reshape(-1, model.dof)
        both = np.isfinite(m[:, space]) & np.isfinite(m[:, 0]) & (m[:, space] > 0)
        if both.any():
            spin = contact.radius ** 2 * float(np.max(m[both, 0] / m[both, space]))
        m = m[:, :space]
    m = m[np.isfinite(m) & (m > 0)]
    if not m.size:
        return fr
    lam = fr.omega_max ** 2 + 2 * coordination(space) * bound_stiffness(contact, spin) / m.min()
    return Frequency(float(np.sqrt(lam)), fr.method + " + contact bound")


def verdict(scene, spec, fr: Frequency):
    """(critical step, problem message or None) of partition ``spec`` at ``fr``."""
    integrator = integrators.make(spec)
    limit = integrator.critical_omega_h()
    if scene.damping.active and not integrator.implicit:
        xi = scene.damping.ratio(fr.omega_max)
        limit = 2.0 * (np.sqrt(1.0 + xi * xi) - xi)
    limit, why = scene.scheme.step_limit(scene, spec, limit)     # the coupling scheme's rule
    crit = fr.critical_step(limit)
    dt = spec.ratio * scene.time.dt
    problem = None
    if fr.omega_max * dt >= limit:
        step, critical = seconds(dt, crit)
        base, = seconds(scene.time.dt)
        problem = (f"partition '{spec.name}': step {step} s (ratio {spec.ratio} x time.dt "
                   f"{base} s) is unstable, critical step {critical} s "
                   f"(omega_max {fr.omega_max:.4g} rad/s, {fr.method}{why}); reduce time.dt or "
                   "the ratio")
    return crit, problem


def damping_need(scene, freqs):
    """(the damping.beta a sub-cycled transition scheme needs [s], the dem
    partition's Frequency); 0 where the dem frequency is unknown or 0."""
    dem = next(p for p in scene.partitions if p.method == "dem")
    fr = freqs.get(dem.name, (None,))[0]
    if fr is None or fr.omega_max <= 0:
        return 0.0, fr
    return 2 * TRANSITION_XI / fr.omega_max, fr


def largest_stable_ratio(scene, freqs) -> tuple[int | None, str | None]:
    """(the largest FE step ratio of a transition scene at its time.dt that the
    guard accepts, the partition that no FE ratio makes stable or None), by the
    rules that decide: the FE side's :func:`verdict` at that ratio, the other
    partitions' verdicts, and above ratio 1 the damping that sub-cycling needs
    (:func:`damping_need`).  Ratio 0: none; None: not known yet (a
    frequency still to be computed)."""
    fem = next(p for p in scene.partitions if p.method == "fem")
    if any(freqs.get(p.name, (None,))[0] is None for p in scene.partitions):
        return None, None
    for p in scene.partitions:
        if p is not fem and verdict(scene, p, freqs[p.name][0])[1]:
            return 0, p.name
    fr = freqs[fem.name][0]
    crit = verdict(scene, fem, fr)[0]
    damped = scene.damping.beta >= damping_need(scene, freqs)[0] * (1 - 1e-12)
    if not np.isfinite(crit):                      # the FE side steps nothing
        return (None if damped else 1), None
    # the FE verdict is monotone in the ratio: the largest one is floor(crit / dt) up to rounding
    top = int(crit / scene.time.dt) + 1
    for ratio in range(top, max(top - 3, 0), -1):
        if verdict(scene, replace(fem, ratio=ratio), fr)[1] is None:
            return (ratio if damped or ratio == 1 else 1), None
    return 0, None
