"""f_int(u) of a dem partition whose particles rotate, joined by 2D beam bonds
(``model.lattice.bond: beam``).

Every particle carries (u_x, u_y, theta) (the model's nodes have three DOFs;
:mod:`solver.model.continuum`), and its bonds are the co-rotational beams of
:mod:`solver.partitions.beam_bond`, evaluated by the compiled loop of
:mod:`solver.partitions.beam_bond_kernel` from the current positions and
rotations: a rigid motion of a bonded cluster, however large its rotation,
exerts no force or torque.  The ghost particles (another piece's, on a
partition split over ranks), the bond order and the energy shares are those
of :class:`~solver.partitions.bonds.BondForce`, which this extends; the
other elements (bonds carried to a transition band's nodes) stay linear,
one MatMult.  Beam bonds do not break, touch or heat yet (the scene refuses
break_strain, contact and heat with them).
"""
from __future__ import annotations

import numpy as np

from solver.partitions.beam_bond import BeamBonds
from solver.partitions.bonds import BondForce


class BeamBondForce(BondForce):
    """Co-rotational beam bonds between rotating particles (2D)."""

    def __init__(self, part, lattice_block, linear_op, other_blocks, tangent):
        super().__init__(part, lattice_block, linear_op, other_blocks, tangent, None)
        # lazy: numba loads only when a partition with beam bonds is built
        from solver.partitions.beam_bond_kernel import beam_forces
        self._beam_forces = beam_forces
        conn, stiff = lattice_block
        at = {(int(a), int(b)): n for n, (a, b) in enumerate(conn.tolist())}
        k_b = stiff.k_b[[at[(int(a), int(b))] for a, b in self.nodes.tolist()]]
        self.beams = BeamBonds(self.i, self.j, self.dX, self.k, k_b)
        self._u = np.zeros((len(self.X), part.dof))     # (u_x, u_y, theta) of held + ghosts
        self.space = self.X.shape[1]

    def separations(self, u, bonds=slice(None)):
        return self.dX[bonds] + (u[self.j[bonds], :2] - u[self.i[bonds], :2])

    def internal(self, u_vec, out_vec):
        """out = f_int(u): forces and torques of the beams (compiled loop),
        plus the carried bonds' linear operator."""
        q, n = self.displacements(u_vec), self.n_held
        if self.operator is not None:
            self.operator.mult(u_vec, out_vec)
        out = out_vec.getArray().reshape(n, self.dim)
        self._beam_forces(self.beams, q, out, n, accumulate=self.operator is not None)

    def reference_internal(self, u_vec, out_vec):
        """The same in numpy (:class:`~solver.partitions.beam_bond.BeamBonds`)."""
        q, n = self.displacements(u_vec), self.n_held
        force, torque = self.beams.forces(q[:, :2], q[:, 2])
        out = np.column_stack([force, torque])[:n].ravel()
        if self.operator is not None:
            self.operator.mult(u_vec, out_vec)
            out_vec.getArray()[:] += out
        else:
            out_vec.getArray()[:] = out

    def virial(self, u, bonds, c) -> float:
        """sum f_c d_c over ``bonds`` at ``u`` [n, 3]: f = N e1 - V e2 the beam's
        force on its first particle (axial and shear)."""
        return self.beams.virial(u[:, :2], u[:, 2], bonds, c)

    def energy(self, part) -> float:
        """Strain energy of the beams, half to each end this piece owns, plus
        the other elements' (owned rows)."""
        q = self.displacements(part.u)
        total = float(np.dot(self.beams.energies(q[:, :2], q[:, 2]), self._share()))
        if self.operator is not None:
            n = part.n_energy
            self.operator.mult(part.u, part.r)
            total -= 0.5 * float(np.dot(part.U[:n], part.R[:n]))
        return total
