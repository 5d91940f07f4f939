"""Time integrators of a partition, each one step of ``m x'' = f_ext + f_int``.

An integrator works on a partition's PETSc Vecs ``u, v, a`` (held DOFs) and
work Vecs, and asks the partition for two things: ``residual(t, u, v)``
(r = f(t) - K u - C v into ``p.r``) and ``accelerate()`` (a = M^-1 r, keeping external
data as the partition's treatment requires).  Sub-cycling a partition inside a
system step is then a loop of ``step`` calls.
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class NewmarkExplicit:
    """Newmark predictor-corrector, explicit form (diagonal mass solve).

    predictor  u~ = u + h v + h^2 (1/2 - beta) a ;  v~ = v + (1 - gamma) h a
    solve      M a' = f(t+h) - K u~ - C v~
    corrector  u' = u~ + beta h^2 a' ;  v' = v~ + gamma h a'

    Second order for gamma = 1/2.  Stability: omega_max h < 2 for any beta
    (the explicit form is only conditionally stable, whatever seed 000 says).
    """

    beta: float = 0.25
    gamma: float = 0.5
    name = "explicit"
    work = ("ut", "vt")

    def describe(self) -> str:
        return f"Newmark explicit (beta={self.beta:g}, gamma={self.gamma:g}), stable for omega*h < 2"

    def step(self, p, t1: float):
        h = p.dt
        p.ut.waxpy(h, p.v, p.u)
        p.ut.axpy(h * h * (0.5 - self.beta), p.a)
        p.vt.waxpy((1.0 - self.gamma) * h, p.a, p.v)
        p.residual(t1, p.ut, p.vt)
        p.accelerate()
        p.u.waxpy(self.beta * h * h, p.a, p.ut)
        p.v.waxpy(self.gamma * h, p.a, p.vt)


@dataclass(frozen=True)
class VelocityVerlet:
    """Velocity Verlet (seed 000 eq. 6 with its typo fixed).

    x' = x + h v + h^2/2 a ;  a' = F(x')/m ;  v' = v + h/2 (a + a')

    Second order, symplectic.  Stability: omega_max h < 2.
    """

    name = "verlet"
    work = ()

    def describe(self) -> str:
        return "velocity Verlet, stable for omega*h < 2"

    def step(self, p, t1: float):
        h = p.dt
        p.u.axpy(h, p.v)
        p.u.axpy(0.5 * h * h, p.a)
        p.v.axpy(0.5 * h, p.a)
        p.residual(t1, p.u, None)
        p.accelerate()
        p.v.axpy(0.5 * h, p.a)


def make(spec):
    """The integrator of a :class:`solver.scene.Partition`."""
    if spec.integrator == "explicit":
        return NewmarkExplicit(spec.beta, spec.gamma)
    if spec.integrator == "verlet":
        return VelocityVerlet()
    raise ValueError(spec.integrator)


CATALOGUE = (NewmarkExplicit, VelocityVerlet)
