"""FEM partition: stiffness as PETSc AIJ over the held DOFs, lumped mass.

For network models the stiffness is assembled from the springs whose both
ends the partition holds; element assembly from meshes plugs in here later.
"""
from __future__ import annotations

from .partition import Partition
from .petscutil import aij


class FemPartition(Partition):
    method = "fem"

    def build_operator(self, model, layout):
        rows, cols, vals = model.stiffness_triplets(layout.held)
        K = aij(rows, cols, vals, self.held_dofs.size, self.comm, self.prefix, scale=-1.0)
        K.setName(f"{self.name}_stiffness")
        n = K.getSize()[0]
        self.built = [f"stiffness matrix {n}x{n} ({int(K.getInfo()['nz_used'])} nonzeros, "
                      f"type {K.getType()})", "lumped mass"]
        return K
