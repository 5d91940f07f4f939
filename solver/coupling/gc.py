"""Gravouil-Combescure (GC) multi-time-step baseline, as Ma et al. (2018) compare against.

The fine (A) and coarse (B) subdomains share duplicated interface nodes, each
copy with half the node's mass (:mod:`solver.coupling.subdomains`).  Velocity
continuity of the copies is enforced by Lagrange multipliers at every fine
step:

    coarse  free step to t_m:  K_eff,B a_B^free = f_B - K_B u~_B
    fine j  free step:         M_A a_A^free = f_A - K_A u~_A
            H lambda_j = -(v_A^free,I - v_B^free,I(t_j)),  v_B^free,I(t_j) linear in j
            a_A += M_A^-1 C_A^T lambda_j, then the Newmark corrector of A
    coarse  a_B += K_eff,B^-1 C_B^T lambda_m, then the corrector of B

with C_A = I, C_B = -I on the interface and H = gamma h M_A^-1 + gamma dT
(K_eff,B^-1)_II, assembled once.

On any number of ranks: with one rank both subdomains step on it; with N > 1
each subdomain has its own ranks (by estimated cost or ``partitions[].ranks``)
and is split over them as every partition is.  X = K_eff,B^-1 C_B^T (one
column per interface node) is solved on the coarse ranks, each keeping its own
rows; H (interface-sized, dense) is replicated on every rank, built once from
X_II and the fine side's interface masses (one allreduce at set-up) and
inverted there.  What crosses sides is interface-sized, so it goes by small
MPI collectives, not a VecScatter: every lambda_j depends on every interface
velocity (H^-1 is dense), so a scatter would be an all-gather anyway.  Per
system step: one allreduce of the coarse free interface velocities (2 x n_I
values) to the fine ranks, one allreduce of the fine free interface
velocities on the fine ranks per fine step (only when the fine side is split)
and one broadcast of lambda_m (n_I values) to the coarse ranks.  Each value
has exactly one owner and the others add zeros, so the sums are exact: the
answers do not depend on N, except through the coarse solve (LU on one rank;
CG + GAMG to rtol 1e-12 on several, since this PETSc build has no parallel
direct solver).
"""
from __future__ import annotations

import numpy as np

from solver.collective import agree, exact_sum
from solver.coupling.scheme import Scheme, two_sides
from solver.coupling.subdomains import NOTE, owned_rows, place
from solver.coupling.system_step import Clocks
from solver.errors import RunFailed, SolverError, StabilityError
from solver.partitions import distribute, ranks, stability
from solver.partitions.partitioning import build_error
from solver.partitions.fem import FemPartition
from solver.petscutil import init
from solver.scene.schema import fail


class OwnSides(Scheme):
    """What the schemes that lay out their own two sides share (gc,
    conserving): no VecScatter exchange, every partition's external data
    taken literally."""
    exchanges = ()
    uses_external = False
    rides = False               # each side on ranks of its own

    @staticmethod
    def treatments(scene) -> list[str]:
        return ["literal"] * len(scene.partitions)


class GravouilCombescure(OwnSides):
    name = "gc"
    summary = ("Gravouil-Combescure baseline (Lagrange multipliers on a duplicated interface; "
               "network models only, any number of ranks)")
    about = ("the Gravouil-Combescure baseline: the interface nodes are duplicated with half "
             "their mass and Lagrange multipliers keep the copies' velocities equal at every fine "
             "step (first order for ratios above 1)")
    supports = ("network models only (springs; not continua, heat or lattices); exactly two "
                "partitions: fem+implicit with the largest ratio and fem+explicit; any number "
                "of ranks (each side on its own ranks from 2, split over several; the coarse "
                "side solves with CG + GAMG on several ranks, LU on one)")
    limit = ("the fine partition's own explicit limit, its interface copies at half mass (the "
             "guard checks that); beyond it nothing is proven: on some chains the coupled step "
             "grows slowly at ratios 2-4 even below that limit (spectral radius up to 1.004, "
             "docs/conserving.md); the energy guard stops a blow-up")
    max_ranks = None

    @classmethod
    def validate(cls, scene):
        if scene.model.kind != "network":
            fail("coupling.scheme", f"gc supports network models only (springs between "
                 f"masses), not a {scene.model.kind} model: use staggered or conserving")
        _, fine = two_sides(scene, cls.name)
        if (fine.method, fine.integrator) != ("fem", "explicit"):
            fail("coupling.scheme", f"gc: the fine partition '{fine.name}' must be fem with "
                 "integrator explicit")
        super().validate(scene)

    @classmethod
    def build(cls, scene, model, comm, say, assignment=None):
        """``assignment``: the ranks to build on instead of those by estimated
        cost (:mod:`solver.driver.balance`)."""
        return cls(scene, model, comm, say, assignment)

    def __init__(self, scene, mdl, comm, say=None, assignment=None):
        P = init()
        self.comm = comm
        plan, shares, self.model = place(scene, mdl, comm, assignment)
        a, b = plan.index
        specs, iface = scene.partitions, plan.iface
        self.assignment, self.layouts, self.iface = plan.assignment, plan.layouts, iface
        self.owned_counts = [lay.n_owned for lay in plan.layouts]
        if comm.size > 1 and say is not None:
            for line in plan.assignment.lines([p.name for p in specs]):
                say(line)
        built = self._build(scene, plan, shares)
        self.A, self.B = built.get(a), built.get(b)
        self.parts = [built[p] for p in sorted(built)]
        self.models = {built[p].name: shares[p] for p in built}
        self.m = scene.system_ratio // specs[a].ratio
        ni = self.ni = iface.size
        self._ga = specs[a].gamma * (specs[a].ratio * scene.time.dt)   # gamma h of A
        self._gb = specs[b].gamma * (specs[b].ratio * scene.time.dt)   # gamma dT of B
        self.root_a = plan.assignment.ranks[a][0]          # broadcasts lambda_m
        # every rank: [v_B(t_0) | v_B^free(t_m)] on the interface, lambda, the fine sums
        self._vb_own, self._vb = np.zeros(2 * ni), np.zeros(2 * ni)
        self.lam = np.zeros(ni)
        share = np.zeros(ni * ni + ni)           # this rank's rows of X_II | masses m_A,I
        try:
            if self.A is not None:
                self.a_rows, self.a_ks = owned_rows(self.A, iface)
                self._va_own, self._va = np.zeros(ni), np.zeros(ni)
                share[ni * ni + self.a_ks] = self.A.mass[self.a_rows]
            if self.B is not None:
                self.b_rows, self.b_ks = owned_rows(self.B, iface)
                self.X = self._columns(P)        # X = K_eff,B^-1 C_B^T, this piece's rows
                share[:ni * ni].reshape(ni, ni)[self.b_ks] = self.X[self.b_rows]
            error = None
        except SolverError as e:
            error = e
        try:
            agree(comm, error)
        except BaseException:
            for part in self.parts:
                part.destroy()
            raise
        if comm.size > 1:
            share, = exact_sum(comm, share)
        X_II, m_I = share[:ni * ni].reshape(ni, ni), share[ni * ni:]
        # H = gamma h M_A^-1 + gamma dT C_B X_II (C_B = -I), replicated
        H = self._ga * np.diag(1.0 / m_I) - self._gb * X_II
        self.H_inv = np.linalg.inv(H)
        self.clocks = Clocks(self.parts, [p.name for p in specs], comm)

    def _build(self, scene, plan, shares) -> dict:
        """This rank's pieces {partition index: FemPartition} (collective), with
        the stability of subdomains too large for the dense check."""
        comm, R = self.comm, scene.system_ratio
        comms = ranks.communicators(comm, plan.assignment)
        self.freqs, built, error, name = dict(plan.freqs), {}, None, "?"
        try:
            for p in plan.assignment.partitions_on(comm.rank):
                spec, model = scene.partitions[p], shares[p]
                name = spec.name
                piece = distribute.piece_on(plan.dists, plan.assignment, p, comm.rank)
                built[p] = FemPartition(spec, piece, model, comms[p], "literal", scene.time.dt, R,
                                        scene.damping, dist=plan.dists[p])
        except SolverError as e:
            error = e
        except Exception as e:                   # noqa: BLE001 -- PETSc errors from options
            error = build_error(name, e)
        try:
            agree(comm, error)
            local, problems = {}, []
            for part in built.values():          # collective on the subdomain's ranks
                if self.freqs[part.name][0] is None:
                    fr, crit, problem = stability.assembled(scene, part)
                    local[part.name] = (fr, crit)
                    problems += [problem] if problem else []
            for chunk in (comm.allgather(local) if comm.size > 1 else [local]):
                self.freqs.update(chunk)
            agree(comm, StabilityError(f"{problems[0]} ({NOTE})") if problems else None)
        except BaseException:
            for part in built.values():
                part.destroy()
            raise
        return built

    def _columns(self, P) -> np.ndarray:
        """X = K_eff,B^-1 C_B^T, C_B = -I on the interface: one solve per interface
        node on the coarse ranks (collective there); this piece's rows."""
        B = self.B
        rhs, sol = B.ksp.getOperators()[0].createVecs()
        first = rhs.getOwnershipRange()[0]
        rows = dict(zip(self.b_ks.tolist(), self.b_rows.tolist()))
        X = np.zeros((B.n_own, self.ni))
        try:
            for k in range(self.ni):
                rhs.set(0.0)
                if k in rows:
                    rhs.setValue(first + rows[k], -1.0)
                rhs.assemble()
                B.ksp.solve(rhs, sol)
                if B.ksp.getConvergedReason() < 0:
                    raise RunFailed(f"partition '{B.name}': the solve of K_eff^-1 for the GC "
                                    f"interface did not converge (reason "
                                    f"{B.ksp.getConvergedReason()}); check -{B.prefix}ksp_* "
                                    f"options")
                X[:, k] = sol.getArray()
        finally:
            rhs.destroy()
            sol.destroy()
        return X

    def describe(self) -> str:
        text = (f"GC baseline (Gravouil-Combescure): {self.iface.size} interface node(s) "
                f"{self.iface.tolist()[:6]} duplicated with half mass, velocity continuity by "
                f"Lagrange multipliers at every fine step")
        if self.comm.size > 1:
            text += (f"; {self.ni}x{self.ni} H replicated, per system step one allreduce of "
                     f"2 x {self.ni} coarse interface velocities, one broadcast of {self.ni} "
                     "multipliers and, with the fine side split, one allreduce on its ranks "
                     "per fine step")
        return text

    def initialise(self, model):
        for part in self.parts:
            part.initialise(self.models[part.name])

    def synchronise(self):
        """Nothing to refresh: the interface is solved within the step."""

    def _coarse_free(self, t_m):
        B, rows, ks, ni = self.B, self.b_rows, self.b_ks, self.ni
        B.integrator.predict(B)
        B.residual(t_m, B.ut, B.vt)
        B.accelerate()
        self._vb_own[ks] = B.V[rows]
        self._vb_own[ni + ks] = B.work_array("vt")[rows] + self._gb * B.A[rows]

    def _to_fine(self):
        """The coarse interface velocities to every rank."""
        exact_sum(self.comm, self._vb_own, out=self._vb)

    def _fine(self, t0):
        A, rows, ks, m, ni = self.A, self.a_rows, self.a_ks, self.m, self.ni
        vb = self._vb if self.comm.size > 1 else self._vb_own
        vB0, vB_free = vb[:ni], vb[ni:]
        Vt, At = A.work_array("vt"), A.A
        split = A.comm.size > 1
        va = self._va if split else self._va_own
        for j in range(1, m + 1):
            A.integrator.predict(A)
            A.residual(t0 + j * A.dt, A.ut, A.vt)
            A.accelerate()
            self._va_own[ks] = Vt[rows] + self._ga * At[rows]
            if split:
                exact_sum(A.comm, self._va_own, out=va)
            vB = (1 - j / m) * vB0 + (j / m) * vB_free
            self.lam[:] = self.H_inv @ (-(va - vB))
            At[rows] += self.lam[ks] / A.mass[rows]
            A.integrator.correct(A)
            A.after_step()

    def _to_coarse(self):
        """lambda_m from the fine side's first rank to every rank."""
        self.comm.Bcast(self.lam, root=self.root_a)

    def _coarse_link(self):
        B = self.B
        B.A[:B.n_own] += self.X @ self.lam
        B.integrator.correct(B)
        B.after_step()

    def step(self, t0: float):
        clocks, several = self.clocks, self.comm.size > 1
        if self.B is not None:
            clocks.part(self.B, self._coarse_free, t0 + self.B.dt)
        if several:
            clocks.exchange(self._to_fine)
        if self.A is not None:
            clocks.part(self.A, self._fine, t0)
        if several:
            clocks.exchange(self._to_coarse)
        if self.B is not None:
            clocks.part(self.B, self._coarse_link)
