"""DEM partition: particles in structure-of-arrays fields, bonds between them.

Particles are the partition's held nodes; their named fields (like DMSwarm's)
are views of the partition state.  Bonds are linear springs: scalar springs
of a network (j = -1 for the ground), or the central bonds of a lattice
(k n n^T blocks, see :mod:`solver.model.lattice`).  Bond forces are applied through
the bond operator, the linear map x -> sum of bond forces, assembled once from
the bonds the partition holds (one MatMult per step), behind the force
interface of :mod:`solver.partitions.force`.
"""
from __future__ import annotations

from solver.partitions.force import LinearForce
from solver.partitions.partition import Partition


class DemPartition(Partition):
    method = "dem"

    def build_force(self, model, layout):
        n_p, dof = layout.n_held, self.dof
        self.fields = {
            "mass": self.mass.reshape(n_p, dof),
            "displacement": self.U.reshape(n_p, dof),
            "velocity": self.V.reshape(n_p, dof),
            "acceleration": self.A.reshape(n_p, dof),
            "global_id": layout.held,
        }
        blocks = model.bond_blocks(self.whole_held())
        B = self.operator(blocks, scale=-1.0)
        B.setName(f"{self.name}_bonds")
        self.built = [f"particles {n_p} ({layout.n_owned} owned), fields "
                      f"{', '.join(self.fields)}",
                      f"bond operator {B.getSize()[0]}x{B.getSize()[0]} (type {B.getType()}, "
                      f"block size {dof})"]
        return LinearForce(B, blocks)
