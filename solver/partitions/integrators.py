"""Time integrators of a partition, each one step of ``m x'' = f_ext + f_int``.

An integrator works on a partition's PETSc Vecs ``u, v, a`` (held DOFs) and
work Vecs, and asks the partition for: ``residual(t, u, v)`` (r = f(t) - K u
- C v into ``p.r``), ``accelerate()`` (a from r: diagonal mass solve or KSP,
keeping external data as the partition's treatment requires) and
``corrected`` (the Vecs the corrector updates: all held rows, or the owned
rows when external data are prescribed from outside).  Sub-cycling a partition inside a
system step is then a loop of ``step`` calls.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar


class Integrator:
    """What a partition and a scheme ask an integrator (one class per
    integrator; ``make`` picks the class by the scene name):

    name        the ``partitions[].integrator`` value
    implicit    the acceleration solve is K_eff a = r (a KSP), not M a = r
    needs_ksp   the partition builds the effective matrix and its KSP
    work        names of the work Vecs the partition makes for it (``p.ut``)
    mass_damping_factor(h, alpha)  the lumped mass is divided by it: explicit
                Newmark folds gamma h alpha M into its diagonal solve
    critical_omega_h(), describe(), step(p, t1), bind(p) -> step(t1)
    """

    name: ClassVar[str] = "?"
    implicit: ClassVar[bool] = False
    needs_ksp: ClassVar[bool] = False
    work: ClassVar[tuple] = ()

    def mass_damping_factor(self, h: float, alpha: float) -> float:
        return 1.0

    def reaction_shift(self, h: float, beta: float) -> float:
        """c such that the residual at the step's final state is the one the step
        evaluated plus c (-K a') on rows held at a' = 0 (the prescribed rows:
        :mod:`solver.partitions.motion`); ``beta``: the Rayleigh stiffness term."""
        return 0.0


@dataclass(frozen=True)
class Newmark(Integrator):
    """Newmark predictor-corrector; explicit (diagonal mass solve) or implicit
    (effective-matrix solve) form of the same code path.

    predictor  u~ = u + h v + h^2 (1/2 - beta) a ;  v~ = v + (1 - gamma) h a
    solve      explicit  M a' = f(t+h) - K u~ - C v~
               implicit  (M + gamma h C + beta h^2 K) a' = f(t+h) - K u~ - C v~
    corrector  u' = u~ + beta h^2 a' ;  v' = v~ + gamma h a'

    Second order for gamma = 1/2.  With Rayleigh damping the explicit form
    solves (M + gamma h alpha M) a' = f - K u~ - C v~ (still diagonal), second
    order in alpha, first order in the stiffness-proportional beta_R (its force
    uses v~); the implicit form is second order in both.  Stability: the explicit form needs
    omega_max h < 2 for any beta; the implicit form is unconditionally stable
    for 2 beta >= gamma >= 1/2, else omega_max h < 1/sqrt(gamma/2 - beta).
    ``predict`` and ``finish`` are separate so that the staggered scheme can
    set prescribed external accelerations in between.
    """

    beta: float = 0.25
    gamma: float = 0.5
    work: ClassVar[tuple] = ("ut", "vt")
    about = ("fem partitions, integrator explicit or implicit: Newmark predictor-corrector "
             "(partitions[].beta, gamma; default 0.25, 0.5), second order for gamma 0.5. "
             "explicit: lumped mass, no solve; stable for omega_max h < 2 whatever beta "
             "(beta 0: central difference). implicit: M + gamma h C + beta h^2 K solved once "
             "per step (a KSP, PETSc options with the partition's prefix); unconditionally "
             "stable for 2 beta >= gamma >= 0.5, else omega_max h < 1/sqrt(gamma/2 - beta)")

    def critical_omega_h(self) -> float:
        """Largest stable omega*h."""
        if not self.implicit:
            return 2.0
        if 2 * self.beta >= self.gamma >= 0.5:
            return float("inf")
        return 1.0 / (self.gamma / 2 - self.beta) ** 0.5

    def reaction_shift(self, h: float, beta: float) -> float:
        """r is evaluated at u~, v~; the corrector adds beta h^2 a' and gamma h a'."""
        return self.beta * h * h + self.gamma * h * beta

    def describe(self) -> str:
        lim = self.critical_omega_h()
        stab = "unconditionally stable" if lim == float("inf") else f"stable for omega*h < {lim:.3g}"
        return f"Newmark {self.name} (beta={self.beta:g}, gamma={self.gamma:g}), {stab}"

    def predict(self, p):
        h = p.dt
        p.ut.waxpy(h, p.v, p.u)
        p.ut.axpy(h * h * (0.5 - self.beta), p.a)
        p.vt.waxpy((1.0 - self.gamma) * h, p.a, p.v)

    def finish(self, p, t1: float):
        p.residual(t1, p.ut, p.vt)
        p.accelerate()
        self.correct(p)

    def correct(self, p):
        """u = u~ + beta h^2 a ;  v = v~ + gamma h a (on ``p.corrected``)."""
        h = p.dt
        u, v, a, ut, vt = p.corrected
        u.waxpy(self.beta * h * h, a, ut)
        v.waxpy(self.gamma * h, a, vt)

    def step(self, p, t1: float):
        self.predict(p)
        self.finish(p, t1)

    def bind(self, p):
        """``step`` for partition ``p`` as a closure over bound methods: the
        same operations without attribute look-ups (it runs every step)."""
        h = p.dt
        u, v, a, ut, vt = p.u, p.v, p.a, p.ut, p.vt
        c_pred, c_vel = h * h * (0.5 - self.beta), (1.0 - self.gamma) * h
        c_u, c_v = self.beta * h * h, self.gamma * h
        ut_waxpy, ut_axpy, vt_waxpy = ut.waxpy, ut.axpy, vt.waxpy
        cu, cv, ca, cut, cvt = p.corrected
        u_waxpy, v_waxpy = cu.waxpy, cv.waxpy
        residual, accelerate = p.residual, p.accelerate

        def step(t1):
            ut_waxpy(h, v, u)
            ut_axpy(c_pred, a)
            vt_waxpy(c_vel, a, v)
            residual(t1, ut, vt)
            accelerate()
            u_waxpy(c_u, ca, cut)
            v_waxpy(c_v, ca, cvt)
        return step


@dataclass(frozen=True)
class ExplicitNewmark(Newmark):
    """Newmark, explicit form: the lumped (diagonal) mass solve."""

    name: ClassVar[str] = "explicit"

    def mass_damping_factor(self, h: float, alpha: float) -> float:
        """(M + gamma h alpha M) a = f - K u~ - C v~: second order in alpha, still diagonal."""
        return 1.0 + self.gamma * h * alpha


@dataclass(frozen=True)
class ImplicitNewmark(Newmark):
    """Newmark, implicit form: K_eff = M + gamma h C + beta h^2 K solved by a KSP."""

    name: ClassVar[str] = "implicit"
    implicit: ClassVar[bool] = True
    needs_ksp: ClassVar[bool] = True


@dataclass(frozen=True)
class VelocityVerlet(Integrator):
    """Velocity Verlet (Li et al. 2023, eq. 6 with its typo fixed).

    x' = x + h v + h^2/2 a ;  a' = F(x', v + h/2 a)/m ;  v' = v + h/2 (a + a')

    Second order, symplectic without damping (damping forces use the half-step
    velocity, first order in the damping terms).  Stability: omega_max h < 2
    undamped, 2 (sqrt(1 + xi^2) - xi) with damping ratio xi at omega_max.
    """

    name: ClassVar[str] = "verlet"
    about = ("dem partitions, integrator verlet: velocity Verlet, second order, symplectic "
             "without damping (first order in the damping terms); stable for omega_max h < 2, "
             "2 (sqrt(1 + xi^2) - xi) with damping ratio xi at omega_max")

    def critical_omega_h(self) -> float:
        return 2.0

    def reaction_shift(self, h: float, beta: float) -> float:
        """r is evaluated at the final u and the half-step v; v' adds h/2 a'."""
        return 0.5 * h * beta

    def describe(self) -> str:
        return "velocity Verlet, stable for omega*h < 2"

    def step(self, p, t1: float):
        self.bind(p)(t1)

    def bind(self, p):
        """``step`` for partition ``p`` as a closure over bound methods."""
        h = p.dt
        u, v, a = p.u, p.v, p.a
        u_maxpy, v_axpy = u.maxpy, v.axpy
        hh, half = 0.5 * h * h, 0.5 * h
        residual, accelerate = p.residual, p.accelerate
        coefs, vecs = (h, hh), (v, a)

        def step(t1):
            u_maxpy(coefs, vecs)        # u += h v + h^2/2 a: one pass (VecMAXPY)
            v_axpy(half, a)
            residual(t1, u, v)          # v is the half-step velocity (used by damping only)
            accelerate()
            v_axpy(half, a)
        return step


@dataclass(frozen=True)
class Levelled(Integrator):
    """Velocity Verlet by element levels (``partitions: auto``): the elements of
    ratio r act every r fine steps (:mod:`solver.partitions.subcycling`); the
    partition's step is the largest ratio's."""

    levels: object = None            # solver.partitions.levels.Levels
    name: ClassVar[str] = "levels"
    about = ("partitions: auto, integrator levels: velocity Verlet by element levels (the "
             "impulse multiple-time-step method): the elements whose stable step allows r x "
             "time.dt act every r fine steps, all nodes drift every fine step; symplectic, "
             "second order; every level stable alone (omega_r r dt < 2, checked before "
             "stepping)")

    def critical_omega_h(self) -> float:
        """The partition's own step is the largest level's: each level is
        checked on its own operator when the partition is built."""
        return float("inf")

    def describe(self) -> str:
        ratios = ", ".join(str(r) for r in self.levels.ratios)
        return f"velocity Verlet by levels (ratios {ratios} x {self.levels.h:.4g} s)"

    def bind(self, p):
        from solver.partitions import subcycling  # lazy: subcycling imports stability, which imports this module
        return subcycling.bind(p, self.levels)


CATALOGUE = (Newmark, VelocityVerlet, Levelled)  # the user texts (``about``) of ``schemes``
KINDS = {cls.name: cls for cls in (ExplicitNewmark, ImplicitNewmark, VelocityVerlet, Levelled)}


def kind(spec) -> type:
    """The integrator class of a :class:`solver.scene.Partition` (``kind(spec).implicit``)."""
    try:
        return KINDS[spec.integrator]
    except KeyError:
        raise ValueError(spec.integrator) from None


def make(spec) -> Integrator:
    """The integrator of a :class:`solver.scene.Partition`."""
    cls = kind(spec)
    if cls is Levelled:
        return cls(getattr(spec, "levels", None))
    return cls(spec.beta, spec.gamma) if issubclass(cls, Newmark) else cls()
