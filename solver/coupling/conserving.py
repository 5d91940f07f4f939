"""Energy-conserving multi-time-step coupling (``coupling.scheme: conserving``).

Two partitions on a node-matching interface: the *fine* one (fem, explicit
Newmark) and the *coarse* one (fem, implicit average acceleration, the largest
ratio m).  The interface nodes I are the coarse partition's nodes with an
element (cell, bond or spring) to a fine node; the coarse side holds them with
their full mass and loads, the fine side holds them as massless externals.
Each element belongs to one side: the fine side takes those with a fine node.

One system step, from t_0 to t_m = t_0 + m h (docs/conserving.md):

- the fine side's interface displacement follows the coarse side's straight
  line, u_I(t_j) = u_I(t_0) + j h V (V: the coarse interface's mean velocity,
  V = (u_I(t_m) - u_I(t_0)) / (m h));
- the coarse side's interface force over its step is the trapezoidal mean of
  the fine side's interface reactions r_j = (K_fine u_j)_I,
  Lambda = -(1/m) [r_0 / 2 + r_1 + ... + r_m-1 + r_m / 2];
- V is solved so that both hold: one small dense system Z V = b with
  Z = m h I + 2 beta (m h)^2 X_II Rbar, constant, factored once (PETSc LU);
  X_II = (K_eff^-1)_II of the coarse side and Rbar the fine side's mean
  reaction per unit V, both computed at set-up.

The fine side's work on the interface is then exactly the coarse side's
negative work: the sum of the fine side's modified (shadow) energy
1/2 v-^T M v+ + 1/2 u^T K u (half-step velocities) and the coarse side's
energy is conserved to round-off, for any ratio, so the scheme is stable
whenever each side is (fine: its explicit limit with the interface nodes at
full mass).  The fine side steps once per fine step; its response to V is
linear and precomputed (response matrix S over the rows it reaches), so the
coupling costs one extra coarse solve and one small dense solve per system
step.  Linear partitions only; loads on the coarse side; 1 rank.
"""
from __future__ import annotations

import numpy as np

from solver.coupling.overlap import Layout
from solver.coupling.system_step import _Clocks
from solver.errors import LaunchError, SceneError, StabilityError
from solver.partitions import stability
from solver.partitions.fem import FemPartition
from solver.petscutil import init


class SideModel:
    """The model as one side sees it: only the side's elements, its masses and
    loads; everything else is the model's."""

    def __init__(self, model, keep, loads):
        self._model, self._keep, self.loads = model, keep, loads

    def __getattr__(self, name):
        return getattr(self._model, name)

    def stiffness_blocks(self, held):
        out = []
        for conn, Ke in self._model.stiffness_blocks(held):
            keep = self._keep(conn)
            if keep.all():
                out.append((conn, Ke))
            elif keep.any():
                out.append((conn[keep], Ke.subset(keep) if hasattr(Ke, "subset") else Ke[keep]))
        return out

    def bond_blocks(self, held):
        return self.stiffness_blocks(held)


def split(scene, mdl):
    """(fine index, coarse index, interface nodes, fine model, coarse model)."""
    parts = scene.partitions
    c = max(range(2), key=lambda k: (parts[k].integrator == "implicit", parts[k].ratio))
    f = 1 - c
    n = mdl.n_nodes
    fine = np.zeros(n + 1, bool)                      # slot -1: springs to the ground
    fine[np.asarray(parts[f].nodes, dtype=np.int64)] = True
    indptr, col = mdl.graph()
    row = np.repeat(np.arange(n), np.diff(indptr))
    iface = np.unique(col[fine[row] & ~fine[col]])
    if not iface.size:
        raise SceneError(f"coupling.scheme: conserving: partitions '{parts[f].name}' and "
                         f"'{parts[c].name}' share no element (no interface)")
    on_iface = np.zeros(n + 1, bool)
    on_iface[iface] = True
    loaded = [int(mdl.dofmap.node_of(ld.dof)[0]) for ld in mdl.loads]
    bad = [k for k in loaded if fine[k]]
    if bad:
        raise SceneError(f"loads: node {bad[0]} is in the fine partition '{parts[f].name}'; "
                         "coupling.scheme conserving takes loads on the coarse partition only")
    if getattr(mdl, "heat", None) is not None:
        raise SceneError("heat: coupling.scheme conserving couples linear partitions without heat")

    def on_fine(conn):
        return fine[conn].any(axis=1)
    m_fine = SideModel(mdl, on_fine, ())
    m_coarse = SideModel(mdl, lambda conn: ~on_fine(conn), mdl.loads)
    return f, c, iface, m_fine, m_coarse


class Conserving:
    name = "conserving"
    exchanges = ()

    @staticmethod
    def treatments(scene) -> list[str]:
        return ["literal"] * len(scene.partitions)

    @classmethod
    def build(cls, scene, model, comm, say):
        if comm.size != 1:
            raise LaunchError("coupling.scheme conserving runs on 1 rank")
        scheme = cls(scene, model)
        scheme.layouts, scheme.model = [p.layout for p in scheme.parts], model
        return scheme

    def __init__(self, scene, mdl):
        P = init()
        f, c, iface, m_fine, m_coarse = split(scene, mdl)
        specs = scene.partitions
        if getattr(mdl, "bond_geometry", "linear") != "linear":
            raise SceneError("model.lattice: coupling.scheme conserving needs linear partitions")
        owned_f = np.unique(np.asarray(specs[f].nodes, dtype=np.int64))
        owned_c = np.unique(np.asarray(specs[c].nodes, dtype=np.int64))
        empty = np.zeros(0, dtype=np.int64)
        lay_f = Layout(specs[f].name, f, owned_f, empty, owned_f, (iface,),
                       np.full(iface.size, c, dtype=np.int64))
        lay_c = Layout(specs[c].name, c, owned_c, empty, owned_c, (), empty)
        self.freqs = {}
        for spec, m, lay in ((specs[f], m_fine, lay_f), (specs[c], m_coarse, lay_c)):
            fr, crit, problem = stability.check(scene, spec, m, lay.held)
            self.freqs[spec.name] = (fr, crit)
            if problem:
                raise StabilityError(f"{problem} (conserving scheme: the fine side with its "
                                     "interface nodes at full mass)")
        R, dt = scene.system_ratio, scene.time.dt
        self.F = FemPartition(specs[f], lay_f, m_fine, P.COMM_SELF, "taylor", dt, R, scene.damping)
        self.C = FemPartition(specs[c], lay_c, m_coarse, P.COMM_SELF, "literal", dt, R,
                              scene.damping)
        for part in (self.F, self.C):
            if self.freqs[part.name][0] is None:          # too large for the dense check
                fr, crit, problem = stability.assembled(scene, part)
                self.freqs[part.name] = (fr, crit)
                if problem:
                    raise StabilityError(f"{problem} (conserving scheme)")
        self.parts = [self.F, self.C] if f == 0 else [self.C, self.F]
        self.models = {self.F.name: m_fine, self.C.name: m_coarse}
        self.m = self.F.n_sub
        self.iface = iface
        F, C = self.F, self.C
        dm = mdl.dofmap
        # interface DOFs: free DOFs of the interface nodes, as rows of F (externals) and C
        rows_f = F.starts[F.layout.local(iface)][:, None] + np.arange(dm.counts[iface].max())
        rows_c = C.starts[C.layout.local(iface)][:, None] + np.arange(dm.counts[iface].max())
        ok = (np.arange(rows_f.shape[1])[None, :] < dm.counts[iface][:, None])
        rows_f, rows_c = rows_f[ok], rows_c[ok]
        free = ~C.fixed_dofs[rows_c]
        self.rf, self.rc = rows_f[free], rows_c[free]
        if F.damping:
            F._am[F.n_own:] = 0.0                      # interface inertia is the coarse side's
        F.energies = self._fine_energies
        self._solve_buffers(P)
        self._set_up(P)
        self.clocks = _Clocks(self.parts)
        self.G0 = np.zeros(self.rc.size)
        self.r0 = np.zeros(self.rc.size)

    # ---------------------------------------------------------------- set-up
    def _solve_buffers(self, P):
        n = self.C.n_own
        self._rhs, self._sol = P.Vec().createSeq(n), P.Vec().createSeq(n)

    def _coarse_solve(self, forces):
        """K_eff^-1 E_I forces (the coarse side's acceleration per interface force)."""
        self._rhs.set(0.0)
        self._rhs.getArray()[self.rc] = forces
        self.C.ksp.solve(self._rhs, self._sol)
        return self._sol.getArray()

    def _fine_pass(self, t0, V, loads=True):
        """The fine side's m steps from its current state with the interface on
        u_I(t_0) + s V; returns (mean reaction, last reaction)."""
        F, rf = self.F, self.rf
        F.V[rf], F.A[rf] = V, 0.0
        acc = 0.5 * self.r0
        r = self.r0
        for j in range(1, self.m + 1):
            F.integrator.predict(F)
            F.residual(t0 + j * F.dt, F.ut, F.vt)
            r = -F.R[rf]
            F.accelerate()
            F.integrator.correct(F)
            if loads:
                F.after_step()
            acc = acc + (r if j < self.m else 0.5 * r)
        return acc / self.m, r

    def _set_up(self, P):
        """Responses to a unit interface velocity: the fine side's state S and
        reactions (Rbar mean, Rm last); the coarse X_II; Z factored."""
        F, C, n = self.F, self.C, self.rc.size
        saved = F.state.copy()
        cols, Rbar, Rm = [], np.zeros((n, n)), np.zeros((n, n))
        self.r0 = np.zeros(n)
        for k in range(n):
            F.state[...] = 0.0
            V = np.zeros(n)
            V[k] = 1.0
            Rbar[:, k], Rm[:, k] = self._fine_pass(0.0, V, loads=False)
            cols.append(F.state.reshape(-1).copy())
        F.state[...] = saved
        S = np.array(cols).T
        self.S_rows = np.flatnonzero(np.abs(S).max(axis=1) > 0) if n else np.zeros(0, int)
        self.S = S[self.S_rows]
        self.Rbar, self.Rm = Rbar, Rm
        X = np.array([self._coarse_solve(e)[self.rc] for e in np.eye(n)]).T
        b, T = self.C.integrator.beta, self.C.dt
        self.c_link = 2.0 * b * T * T
        self.X_II = X
        Z = T * np.eye(n) + self.c_link * X @ Rbar
        self.Z = P.Mat().createDense((n, n), array=Z.copy(), comm=P.COMM_SELF)
        self.Z.assemble()
        ksp = P.KSP().create(P.COMM_SELF)
        ksp.setOperators(self.Z)
        ksp.setType("preonly")
        ksp.getPC().setType("lu")
        ksp.setUp()
        self.zksp = ksp
        self._b, self._V = self.Z.createVecs()

    def describe(self) -> str:
        return (f"energy-conserving multi-time-step coupling: {self.iface.size} interface node(s) "
                f"{self.iface.tolist()[:6]}, fine '{self.F.name}' on the coarse side's straight "
                f"interface path, coarse '{self.C.name}' with the fine reactions' trapezoidal "
                f"mean; {self.rc.size}x{self.rc.size} interface system factored once; "
                f"stable by construction at any ratio (here {self.m})")

    def _fine_energies(self):
        """The fine side's energies with the strain energy of its elements on the
        interface rows, which it does not own (1/2 u_I . (K_fine u)_I)."""
        F = self.F
        kinetic, strain, work, dissipated = type(F).energies(F)
        F._internal(F.u, F.r)
        return kinetic, strain - 0.5 * float(np.dot(F.U[self.rf], F.R[self.rf])), work, dissipated

    # -------------------------------------------------------------- stepping
    def initialise(self, model):
        self.F.initialise(self.models[self.F.name])
        self.C.initialise(self.models[self.C.name])
        self._reactions()
        self.G0 = -self.r0                              # consistent initial acceleration
        self.C.A[self.rc] += self.G0 * self.C._minv[self.rc]

    def _reactions(self):
        F = self.F
        F.U[self.rf] = self.C.U[self.rc]
        F.V[self.rf] = self.C.V[self.rc]
        F._internal(F.u, F.r)
        self.r0 = -F.R[self.rf]

    def synchronise(self):
        """The interface state from the coarse side (restarts, the step-matrix
        analysis): fine interface rows, the fine reaction and the coarse side's
        interface force implied by its acceleration."""
        C = self.C
        self._reactions()
        C.residual(0.0, C.u, C.v)
        self.G0 = C.mass[self.rc] * C.A[self.rc] - C.R[self.rc]

    def step(self, t0: float):
        self.clocks.part(self.C, self._coarse_free, t0 + self.C.dt)
        self.clocks.part(self.F, self._fine, t0)
        self.clocks.part(self.C, self._coarse_link)

    def _coarse_free(self, t_m):
        C, rc = self.C, self.rc
        C.integrator.predict(C)
        C.residual(t_m, C.ut, C.vt)
        C.R[rc] -= self.G0                              # G_m = 2 Lambda - G_0 with Lambda = 0
        C.accelerate()
        self.uI0 = C.U[rc].copy()
        self.uI_free = C.work_array("ut")[rc] + C.integrator.beta * C.dt ** 2 * C.A[rc]

    def _fine(self, t0):
        F = self.F
        F.U[self.rf] = self.uI0
        rbar0, rm0 = self._fine_pass(t0, 0.0)
        b = self._b.getArray()
        b[:] = (self.uI_free - self.uI0) - self.c_link * (self.X_II @ rbar0)
        self.zksp.solve(self._b, self._V)
        V = self._V.getArray().copy()
        flat = F.state.reshape(-1)
        flat[self.S_rows] += self.S @ V
        self.r0 = rm0 + self.Rm @ V
        self.Lam = -(rbar0 + self.Rbar @ V)

    def _coarse_link(self):
        C = self.C
        C.A[:C.n_own] += self._coarse_solve(2.0 * self.Lam)
        C.integrator.correct(C)
        C.after_step()
        self.G0 = 2.0 * self.Lam - self.G0
