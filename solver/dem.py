"""DEM partition: particles in structure-of-arrays fields, bonds between them.

Particles are the partition's held nodes; their named fields (like DMSwarm's)
are views of the partition state.  Bonds are linear springs stored as arrays
(i, j, stiffness) with j = -1 for a bond to the ground.  Bond forces are
applied through the bond operator, the linear map x -> sum of bond forces,
assembled once from the bond arrays into PETSc AIJ (one MatMult per step).
"""
from __future__ import annotations

from .model import spring_triplets
from .partition import Partition
from .petscutil import aij


class DemPartition(Partition):
    method = "dem"

    def build_operator(self, model, layout):
        self.bond_i, self.bond_j, self.bond_k = model.springs_within(layout.held)
        n_p, dof = layout.n_held, self.dof
        self.fields = {
            "mass": self.mass.reshape(n_p, dof),
            "displacement": self.U.reshape(n_p, dof),
            "velocity": self.V.reshape(n_p, dof),
            "acceleration": self.A.reshape(n_p, dof),
            "global_id": layout.held,
        }
        rows, cols, vals = spring_triplets(self.bond_i, self.bond_j, self.bond_k)
        B = aij(rows, cols, vals, self.held_dofs.size, self.comm, self.prefix, scale=-1.0)
        B.setName(f"{self.name}_bonds")
        self.built = [f"particles {n_p} ({layout.n_owned} owned), fields "
                      f"{', '.join(self.fields)}",
                      f"bonds {self.bond_k.size} -> bond operator (type {B.getType()})"]
        return B
