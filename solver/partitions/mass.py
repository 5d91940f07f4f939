"""The lumped mass of a partition's held DOFs and the inverse its diagonal
acceleration solve uses.

    mass     [n] lumped mass per held DOF
    fixed    [n] bool: fixed DOFs (they never accelerate)
    inverse  [n] 1 / (factor * mass), 0 on fixed DOFs; factor is the integrator's
             ``mass_damping_factor`` (explicit Newmark folds gamma h alpha M in)
    minv     a PETSc Vec on ``inverse``
"""
from __future__ import annotations

from solver.model.arrays import dof_masses
from solver.petscutil import vec_on


class LumpedMass:
    def __init__(self, model, held_nodes, held_dofs, comm, factor: float = 1.0,
                 prefix: str | None = None):
        self.mass = dof_masses(model, held_nodes)
        self.inverse = 1.0 / self.mass
        self.fixed = model.fixed[held_dofs]
        self.inverse[self.fixed] = 0.0
        if factor != 1.0:
            self.inverse /= factor
        self.minv = vec_on(self.inverse, comm)
        if prefix is not None:
            self.minv.setOptionsPrefix(prefix)

    def destroy(self):
        self.minv.destroy()
