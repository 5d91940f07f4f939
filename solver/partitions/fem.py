"""FEM partition: stiffness as PETSc AIJ over the held DOFs, lumped mass.

For network models the stiffness is assembled from the springs whose both
ends the partition holds; element assembly from meshes plugs in here later.
With ``integrator: implicit`` the partition also holds the effective matrix
K_eff = M + beta h^2 K (assembled once: the step never changes) and a KSP set
up once and reused.  When external accelerations are prescribed (taylor
treatment, staggered scheme) it solves only the owned block:
K_eff[O,O] a_O = r_O - K_eff[O,E] a_E.  Defaults: direct LU on one rank,
CG + GAMG with rtol 1e-12 across ranks; -<name>_ksp_type / -<name>_pc_type
and the other KSP options override them.  A solve that does not converge stops
the run with PETSc's reason.
"""
from __future__ import annotations

import numpy as np

from solver.errors import RunFailed, SceneError

# preconditioners that solve K_eff a = r exactly, so KSP preonly is a solve
DIRECT_PCS = ("lu", "cholesky", "qr", "redundant", "svd")
from solver.partitions import levels
from solver.partitions.force import LinearForce
from solver.partitions.integrators import Levelled
from solver.partitions.partition import Partition
from solver.petscutil import init, vec_on


class FemPartition(Partition):
    method = "fem"
    level_ops: dict = {}          # partitions: auto: ratio -> r dt M^-1 (-K_r) (levels.operators)
    level_vecs: list = []         # their kicks (subcycling.bind)

    def build_force(self, model, layout):
        blocks = model.stiffness_blocks(self.whole_held())
        K = self.operator(blocks, scale=-1.0)
        K.setName(f"{self.name}_stiffness")
        n = K.getSize()[0]
        self.built += [f"stiffness matrix {n}x{n} ({int(K.getInfo()['nz_used'])} nonzeros, "
                      f"type {K.getType()}, block size {K.getBlockSize()})", "lumped mass"]
        force = LinearForce(K, blocks)
        if self.integrator.name == Levelled.name:     # partitions: auto
            self.level_ops = levels.operators(self, blocks, self.integrator.levels)
        if self.integrator.needs_ksp:
            self._build_solver(force.blocks)
        return force

    def _build_solver(self, blocks):
        P = init()
        n = self.held_dofs.size
        h = self.dt
        beta, gamma = self.integrator.beta, self.integrator.gamma
        a_r, b_r = (self.damping.alpha, self.damping.beta) if self.damping else (0.0, 0.0)
        # K_eff = M + gamma h C + beta h^2 K with C = a_r M + b_r K
        K_eff = self.operator(blocks, scale=beta * h * h + gamma * h * b_r,
                              diagonal=(1.0 + gamma * h * a_r) * self.mass, solved=True)
        K_eff.setName(f"{self.name}_effective")
        # fixed DOFs keep a = 0: their rows and columns become the identity and
        # their residual is zeroed before every solve
        lo, hi = K_eff.getOwnershipRange()
        fixed = np.flatnonzero(self.fixed_dofs[:hi - lo])
        self._fixed_rows = fixed[fixed < self._solve[0].getLocalSize()]
        # collective: every rank of the partition calls it when any rank has fixed DOFs
        comm = K_eff.getComm().tompi4py()
        if (comm.allreduce(int(fixed.size)) if comm.size > 1 else fixed.size):
            K_eff.zeroRowsColumns((lo + fixed).astype(P.IntType), diag=1.0)
        self._mats = [K_eff]
        m = self._solve[0].getLocalSize()
        self.K_OE = None
        A = K_eff
        if self._solve[0].getSize() < self.n_global:
            own = P.IS().createStride(m, self.first, 1, comm=self.comm)
            ext = P.IS().createStride(n - m, self.first + m, 1, comm=self.comm)
            A = K_eff.createSubMatrix(own, own)
            self.K_OE = K_eff.createSubMatrix(own, ext)
            self.K_OE.scale(-1.0)
            self._a_ext = vec_on(self.A[m:], self.comm)
            self._mats += [A, self.K_OE, self._a_ext, own, ext]
        ksp = P.KSP().create(self.comm)
        ksp.setOptionsPrefix(self.prefix)
        ksp.setOperators(A)
        if self.comm.size == 1:
            ksp.setType("preonly")
            ksp.getPC().setType("lu")
        else:
            ksp.setType("cg")
            ksp.getPC().setType("gamg")
        # tight enough that an iterative solve chosen by option gives the direct
        # solve's answer to round-off (-<name>_ksp_rtol still overrides)
        ksp.setTolerances(rtol=1e-12)
        ksp.setFromOptions()
        pc = ksp.getPC().getType()
        A = self._blocked_for_lu(ksp, A, pc, P)
        if ksp.getType() == "preonly" and pc not in DIRECT_PCS:
            raise SceneError(f"-{self.prefix}pc_type {pc}: with KSP preonly the preconditioner "
                             f"must solve exactly ({', '.join(DIRECT_PCS)}); add -{self.prefix}"
                             "ksp_type cg (or gmres) to iterate with it")
        ksp.setUp()
        self.ksp = ksp
        self._reasons = {v: k for k, v in vars(P.KSP.ConvergedReason).items() if isinstance(v, int)}
        mg = self._solve[0].getSize()
        self.built.append(f"effective matrix M + gamma h C + beta h^2 K ({mg}x{mg} solved block), KSP "
                          f"{ksp.getType()} + PC {ksp.getPC().getType()} ({A.getType()})")

    def _blocked_for_lu(self, ksp, A, pc, P):
        """A serial LU of vector DOFs factors a BAIJ copy (blocks of dof x dof):
        1.5x faster solves than AIJ with the same fill (the U-tube's 57,600
        shell DOFs: 14.6 vs 22.1 ms); -<prefix>mat_type overrides."""
        if (pc != "lu" or A.getType() != "seqaij" or A.getBlockSize() < 2 or
                P.Options().hasName(f"{self.prefix}mat_type")):
            return A
        B = A.convert("baij")
        ksp.setOperators(B)
        self._mats.append(B)
        return B

    def accelerate(self):
        if not self.integrator.needs_ksp:
            return super().accelerate()
        a, r, _ = self._solve
        if self._fixed_rows.size:
            self.R[self._fixed_rows] = 0.0
        if self.K_OE is not None:
            self.K_OE.multAdd(self._a_ext, r, r)          # r_O - K_eff[O,E] a_E
        self.ksp.solve(r, a)
        reason = self.ksp.getConvergedReason()
        if reason < 0:
            raise RunFailed(f"partition '{self.name}': linear solve did not converge "
                            f"({self._reasons.get(reason, reason)}, {self.ksp.getIterationNumber()} "
                            f"iterations); check -{self.prefix}ksp_* / -{self.prefix}pc_* options")

    def destroy(self):
        super().destroy()
        for obj in [*self.level_ops.values(), *self.level_vecs]:
            obj.destroy()
        if self.integrator.needs_ksp:
            self.ksp.destroy()
            for obj in self._mats:
                obj.destroy()
