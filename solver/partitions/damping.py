"""Rayleigh damping of a partition, C = alpha M + beta K: its terms in the
residual and the work Vecs they need, made only for a damped partition
(``Damping.of`` gives None otherwise).

    alpha, beta  the Rayleigh coefficients (``damping.*``)
    am           [n] alpha M on the held DOFs (the mass-proportional term)
    alpha_m      a Vec on ``am``;  am_v  a work Vec (alpha M v or -K v)

A linear partition's residual is r = f - K u - beta K v - alpha M v; a
nonlinear one takes the stiffness-proportional term with the tangent at rest
(r += -beta K0 v), without the bonds that have broken.  Each term's power
v.C v goes into the energy audit
(:mod:`solver.partitions.audit`).
"""
from __future__ import annotations

import numpy as np

from solver.petscutil import vec_on


class Damping:
    def __init__(self, spec, mass, comm):
        self.alpha, self.beta = spec.alpha, spec.beta
        self.am = self.alpha * mass
        self.am_v = vec_on(np.zeros(mass.size), comm)
        self.alpha_m = vec_on(self.am, comm)

    @classmethod
    def of(cls, spec, mass, comm):
        """The damping of a partition with damping ``spec`` (None: undamped)."""
        return cls(spec, mass, comm) if spec is not None and spec.active else None

    def clear_rows(self, start: int):
        """No mass-proportional damping on rows ``start:`` (another side damps them)."""
        self.am[start:] = 0.0

    def linear(self, internal, u, v, r, audit):
        """r = -K u - beta K v - alpha M v (``internal(x, out)``: out = -K x)."""
        if self.beta:                    # -K u - beta K v, beta v.K v dissipated
            internal(v, self.am_v)
            audit.dissipate(v, self.am_v, -self.beta)
            internal(u, r)
            r.axpy(self.beta, self.am_v)
        else:
            internal(u, r)
        self.mass_term(v, r, audit)

    def nonlinear(self, tangent, v, r, audit, release=None):
        """r += -beta K0 v - alpha M v (``tangent``: -K0, the tangent at rest;
        ``release(v, out)``: out += K_b v of the elements no longer there)."""
        tangent.mult(v, self.am_v)       # -K0 v
        if release is not None and self.beta:
            release(v, self.am_v)
        r.axpy(self.beta, self.am_v)
        audit.dissipate(v, self.am_v, -self.beta)
        self.mass_term(v, r, audit)

    def mass_term(self, v, r, audit):
        """r -= alpha M v."""
        self.am_v.pointwiseMult(self.alpha_m, v)
        r.axpy(-1.0, self.am_v)
        audit.dissipate(v, self.am_v, 1.0)

    def destroy(self):
        for vec in (self.am_v, self.alpha_m):
            vec.destroy()
