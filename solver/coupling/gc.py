"""Gravouil-Combescure (GC) multi-time-step baseline, as Ma et al. (2018) compare against.

A non-overlapping decomposition derived from the scene's node ownership: an
*interface node* is a node of the coarse (implicit) partition with a spring to
the fine (explicit) partition.  Both subdomains hold a copy of it with half its
mass; the fine subdomain takes every spring touching one of its own nodes,
the coarse one the rest; loads on interface nodes stay with the coarse side.
Velocity continuity of the copies is enforced by Lagrange multipliers at every
fine step:

    coarse  free step to t_m:  K_eff,B a_B^free = f_B - K_B u~_B
    fine j  free step:         M_A a_A^free = f_A - K_A u~_A
            H lambda_j = -(v_A^free,I - v_B^free,I(t_j)),  v_B^free,I(t_j) linear in j
            a_A += M_A^-1 C_A^T lambda_j, then the Newmark corrector of A
    coarse  a_B += K_eff,B^-1 C_B^T lambda_m, then the corrector of B

with C_A = I, C_B = -I on the interface and H = gamma h M_A^-1 + gamma dT
(K_eff,B^-1)_II, assembled once.  One rank only.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from solver.partitions import integrators, stability
from solver.coupling.scheme import Scheme, two_sides
from solver.coupling.system_step import Clocks
from solver.partitions.fem import FemPartition
from solver.model.layout import Layout
from solver.petscutil import init
from solver.scene.schema import fail


def subdomains(scene, mdl):
    """(models, layouts, interface nodes) of the fine (A) and coarse (B) subdomains."""
    parts = scene.partitions
    b = next(k for k, p in enumerate(parts) if integrators.kind(p).implicit)
    a = 1 - b
    nodes = [np.asarray(sorted(p.nodes), dtype=np.int64) for p in parts]
    in_a = np.zeros(mdl.n_nodes + 1, bool)
    in_a[nodes[a]] = True
    si, sj = mdl.spring_i, mdl.spring_j
    touches_a = in_a[si] | in_a[sj]              # index -1 (ground) reads the extra slot
    iface = np.unique(np.concatenate([sj[in_a[si] & ~in_a[sj] & (sj >= 0)],
                                      si[in_a[sj] & ~in_a[si] & (si >= 0)]]))
    mass_half = mdl.mass.copy()
    mass_half[iface] *= 0.5
    on_iface = set(iface.tolist())
    model_a = dataclasses.replace(
        mdl, mass=mass_half, spring_i=si[touches_a], spring_j=sj[touches_a],
        spring_k=mdl.spring_k[touches_a],
        loads=tuple(l for l in mdl.loads if int(mdl.dofmap.node_of(l.dof)[0]) not in on_iface))
    model_b = dataclasses.replace(mdl, mass=mass_half, spring_i=si[~touches_a],
                                  spring_j=sj[~touches_a], spring_k=mdl.spring_k[~touches_a])
    held_a = np.concatenate([nodes[a], iface])
    empty = np.zeros(0, dtype=np.int64)

    def layout(name, index, held):
        return Layout(name, index, held, empty, held, (), empty)
    return ((model_a, model_b), (layout(parts[a].name, a, held_a), layout(parts[b].name, b, nodes[b])),
            iface, (a, b))


class OwnSides(Scheme):
    """What the schemes that lay out their own two sides share (gc,
    conserving): no VecScatter exchange, every partition's external data
    taken literally."""
    exchanges = ()
    uses_external = False

    @staticmethod
    def treatments(scene) -> list[str]:
        return ["literal"] * len(scene.partitions)


class GravouilCombescure(OwnSides):
    name = "gc"
    summary = ("Gravouil-Combescure baseline (Lagrange multipliers on a duplicated interface; "
               "network models only, 1 rank)")
    about = ("the Gravouil-Combescure baseline: the interface nodes are duplicated with half "
             "their mass and Lagrange multipliers keep the copies' velocities equal at every fine "
             "step (first order for ratios above 1)")
    supports = ("network models only (springs; not continua, heat or lattices); exactly two "
                "partitions: fem+implicit with the largest ratio and fem+explicit; 1 rank")
    limit = ("the fine partition's own explicit limit, its interface copies at half mass (the "
             "guard checks that); beyond it nothing is proven: on some chains the coupled step "
             "grows slowly at ratios 2-4 even below that limit (spectral radius up to 1.004, "
             "docs/conserving.md); the energy guard stops a blow-up")
    max_ranks = 1

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
    def build(cls, scene, model, comm, say):
        return cls(scene, model, comm)

    def __init__(self, scene, mdl, comm):
        P = init()
        (model_a, model_b), (lay_a, lay_b), iface, (a, b) = subdomains(scene, mdl)
        R, note = scene.system_ratio, "GC subdomain, interface mass halved"
        self.freqs = {}
        built = []
        for spec, m, lay in ((scene.partitions[a], model_a, lay_a),
                             (scene.partitions[b], model_b, lay_b)):
            part, self.freqs[spec.name] = stability.side(
                scene, spec, m, lay.held,
                lambda spec=spec, lay=lay, m=m: FemPartition(spec, lay, m, P.COMM_SELF, "literal",
                                                             scene.time.dt, R, scene.damping),
                note)
            built.append(part)
        self.A, self.B = built
        self.parts = [self.A, self.B] if a == 0 else [self.B, self.A]
        self.models = {self.A.name: model_a, self.B.name: model_b}
        self.m = self.A.n_sub
        self.ia = self.A.layout.local(iface)       # interface rows in A and B
        self.ib = self.B.layout.local(iface)
        # X = K_eff,B^-1 C_B^T (C_B = -I on the interface), H = gamma h M_A^-1 + gamma dT X_II
        nb, ni = self.B.n_own, iface.size
        self.X = np.zeros((nb, ni))
        rhs, sol = P.Vec().createSeq(nb), P.Vec().createSeq(nb)
        for k, row in enumerate(self.ib):
            rhs.set(0.0)
            rhs.setValue(int(row), -1.0)
            self.B.ksp.solve(rhs, sol)
            self.X[:, k] = sol.getArray()
        rhs.destroy()
        sol.destroy()
        ga, gb = scene.partitions[a].gamma, scene.partitions[b].gamma
        H = ga * self.A.dt * np.diag(1.0 / self.A.mass[self.ia]) - gb * self.B.dt * self.X[self.ib]
        self.H_inv = np.linalg.inv(H)
        self._ga, self._gb = ga * self.A.dt, gb * self.B.dt
        self.clocks = Clocks(self.parts)
        self.iface = iface
        self.layouts, self.model = [p.layout for p in self.parts], mdl

    def describe(self) -> str:
        return (f"GC baseline (Gravouil-Combescure): {self.iface.size} interface node(s) "
                f"{self.iface.tolist()[:6]} duplicated with half mass, velocity continuity by "
                f"Lagrange multipliers at every fine step")

    def initialise(self, model):
        self.A.initialise(self.models[self.A.name])
        self.B.initialise(self.models[self.B.name])

    def synchronise(self):
        """Nothing to refresh: the interface is solved within the step."""

    def _coarse_free(self, t_m):
        B = self.B
        B.integrator.predict(B)
        B.residual(t_m, B.ut, B.vt)
        B.accelerate()
        self.vB0 = B.V[self.ib].copy()
        self.vB_free = B.work_array("vt")[self.ib] + self._gb * B.A[self.ib]

    def _fine(self, t0):
        A, ia = self.A, self.ia
        Vt, At = A.work_array("vt"), A.A
        for j in range(1, self.m + 1):
            A.integrator.predict(A)
            A.residual(t0 + j * A.dt, A.ut, A.vt)
            A.accelerate()
            vA_free = Vt[ia] + self._ga * At[ia]
            vB = (1 - j / self.m) * self.vB0 + (j / self.m) * self.vB_free
            self.lam = self.H_inv @ (-(vA_free - vB))
            At[ia] += self.lam / A.mass[ia]
            A.integrator.correct(A)
            A.after_step()

    def _coarse_link(self):
        B = self.B
        B.A[:B.n_own] += self.X @ self.lam
        B.integrator.correct(B)
        B.after_step()

    def step(self, t0: float):
        self.clocks.part(self.B, self._coarse_free, t0 + self.B.dt)
        self.clocks.part(self.A, self._fine, t0)
        self.clocks.part(self.B, self._coarse_link)


