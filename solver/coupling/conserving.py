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
step.  Linear partitions only; loads on either side (the fine side's work is
tracked on its true path).

Ranks: each side runs on its own ranks (shared by estimated cost, or
``partitions[].ranks``; on one rank both share it), split as any partition is
(:mod:`solver.partitions.distribute`).  The fine response S is distributed
with the fine rows (each rank keeps its rows); the interface unknowns stay
small and replicated: each interface DOF is one fine piece's external and one
coarse piece's owned row, so one allreduce of 4 x (interface DOFs) values
per system step gathers the interface vectors exactly, and every rank solves
Z V = b.  A coarse side on several ranks solves with the partition's
default there (CG + GAMG, rtol 1e-12: this PETSc has no parallel direct
solver), so results agree with one rank to the solver's tolerance.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from solver.collective import agree, exact_sum, on_root, scatter_each
from solver.model.layout import Layout
from solver.coupling.scheme import two_sides
from solver.coupling.system_step import Clocks
from solver.coupling.gc import OwnSides
from solver.errors import SceneError, SolverError, StabilityError
from solver.laws import BOND_GEOMETRIES
from solver.partitions import distribute, integrators, ranks, stability
from solver.model.cell_blocks import kept
from solver.partitions.dem import DemPartition
from solver.partitions.fem import DIRECT_PCS, FemPartition
from solver.partitions.partitioning import owned_nonzeros
from solver.petscutil import init, vec_on
from solver.scene.schema import fail


class SideModel:
    """The model as one side sees it: only the side's elements, its masses and
    loads; everything else is the model's."""

    def __init__(self, model, keep, loads):
        self._model, self._keep, self.loads = model, keep, loads

    def __getattr__(self, name):
        return getattr(self._model, name)

    def stiffness_blocks(self, held):
        return self._filter(self._model.stiffness_blocks(held))

    def bond_blocks(self, held):
        return self._filter(self._model.bond_blocks(held))

    def _filter(self, blocks):
        return [kept(conn, Ke, keep) for conn, Ke in blocks
                for keep in [self._keep(conn)] if keep.any()]


def interface(scene, mdl):
    """(fine index, coarse index, interface nodes) from the whole model's node
    graph, with the scheme's refusals (rank 0)."""
    parts = scene.partitions
    f, c = sides(scene)
    n = mdl.n_nodes
    fine = fine_mask(scene, n, f)
    indptr, col = mdl.graph()
    row = np.repeat(np.arange(n), np.diff(indptr))
    iface = np.unique(col[fine[row] & ~fine[col]])
    if not iface.size:
        raise SceneError(f"coupling.scheme: conserving: partitions '{parts[f].name}' and "
                         f"'{parts[c].name}' share no element (no interface)")
    return f, c, iface


def sides(scene):
    """(fine index, coarse index): the coarse side is the implicit partition
    with the largest ratio."""
    parts = scene.partitions
    c = max(range(2), key=lambda k: (integrators.kind(parts[k]).implicit, parts[k].ratio))
    return 1 - c, c


def fine_mask(scene, n_nodes, f):
    fine = np.zeros(n_nodes + 1, bool)                # slot -1: springs to the ground
    fine[np.asarray(scene.partitions[f].nodes, dtype=np.int64)] = True
    return fine


def side_model(scene, mdl, f, k):
    """Partition ``k``'s view of ``mdl``: the fine side takes every element with
    a fine node and the loads on fine nodes, the coarse side the rest."""
    fine = fine_mask(scene, mdl.n_nodes, f)

    def on_fine(conn):
        return fine[conn].any(axis=1)
    nodes = mdl.dofmap.node_of([ld.dof for ld in mdl.loads]) if mdl.loads else \
        (np.zeros(0, np.int64), None)
    mine = fine[nodes[0]] if k == f else ~fine[nodes[0]]
    loads = tuple(ld for ld, keep in zip(mdl.loads, mine) if keep)
    return SideModel(mdl, on_fine if k == f else (lambda conn: ~on_fine(conn)), loads)


def side_layouts(scene, f, iface):
    """The two sides' layouts (whole partitions): the fine side owns its nodes
    and holds the interface nodes as one external layer, the coarse side owns
    its nodes and holds nothing else."""
    out, empty = [], np.zeros(0, dtype=np.int64)
    for k, spec in enumerate(scene.partitions):
        owned = np.unique(np.asarray(spec.nodes, dtype=np.int64))
        if k == f:
            out.append(Layout(spec.name, k, owned, empty, owned, (iface,),
                              np.full(iface.size, 1 - f, dtype=np.int64)))
        else:
            out.append(Layout(spec.name, k, owned, empty, owned, (), empty))
    return out


@dataclass
class Plan:
    """What rank 0 decides for every rank (small arrays, broadcast)."""
    f: int
    c: int
    iface: np.ndarray        # interface nodes
    dofs: np.ndarray         # their free DOFs (model numbering): the interface unknowns
    layouts: list            # both sides, whole
    assignment: object       # ranks.Assignment: the world ranks of each side
    dists: list              # each side over its ranks (distribute.Distribution)
    freqs: dict              # name -> (Frequency, critical step) or (None, None): after building


NOTE = "conserving scheme: the fine side with its interface nodes at full mass"


def plan(scene, mdl, size):
    """On rank 0 with the whole model: the interface, both layouts, the ranks
    of each side (by estimated cost, as for any scheme: :mod:`solver.partitions.ranks`;
    on one rank both sides share it), each side split over its ranks, the
    stability check before building, and every rank's share of the model (the
    elements touching the nodes its pieces hold)."""
    f, c, iface = interface(scene, mdl)
    graph = mdl.graph()
    layouts = side_layouts(scene, f, iface)
    specs = scene.partitions
    R = scene.system_ratio
    costs = [ranks.cost(owned_nonzeros(graph, lay.owned, mdl.dofmap), R // p.ratio)
             for lay, p in zip(layouts, specs)]
    requested = [p.ranks for p in specs] if size > 1 else [None, None]
    assignment = ranks.assign(size, costs, [lay.n_owned for lay in layouts], requested,
                              ride=scene.scheme.rides)
    # a side on one rank keeps its nodes in layout order (the 1- and 2-rank runs' numbering)
    dists = [distribute.split(lay, graph, len(rs)) if len(rs) > 1 else
             distribute.whole(lay, mdl.n_nodes) for lay, rs in zip(layouts, assignment.ranks)]
    freqs = {}
    for k in (f, c):
        fr, crit, problem = stability.check(scene, specs[k], side_model(scene, mdl, f, k),
                                            layouts[k].held)
        if problem:
            raise StabilityError(f"{problem} ({NOTE})")
        freqs[specs[k].name] = (fr, crit)
    gd = mdl.dofmap.dofs(iface)
    gd = gd[~mdl.fixed[gd]]
    shares = [mdl]                           # rank 0 keeps the whole model (it writes fields)
    for r in range(1, size):
        shares.append(mdl.share(distribute.held_on(dists, assignment, r)))
    return Plan(f, c, iface, gd, layouts, assignment, dists, freqs), shares


class Conserving(OwnSides):
    name = "conserving"
    summary = ("energy-conserving multi-time-step coupling of an explicit fem or dem partition "
               "and an implicit one at any ratio (stable by construction; no heat, linear bonds; "
               "docs/conserving.md, any number of ranks)")
    about = ("energy-conserving multi-time-step coupling (docs/conserving.md): the fine "
             "side follows the coarse side's straight displacement path on a shared "
             "interface, and a discrete energy is conserved to round-off")
    supports = ("network and continuum models without heat or prescribed motion and with "
                "linear bonds; exactly "
                "two partitions on a node-matching interface: fem+implicit (average "
                "acceleration: beta 0.25, gamma 0.5) with the largest ratio and fem+explicit "
                "(central difference: beta 0, gamma 0.5) or dem+verlet; any number of ranks "
                "(each side on its own ranks, shared by cost or partitions[].ranks; the "
                "interface system replicated)")
    limit = ("stable at any ratio whenever each side is: the fine side's own explicit "
             "limit with the interface nodes at full mass; the coarse side none")
    max_ranks = None

    @classmethod
    def validate(cls, scene):
        if scene.heat is not None:
            fail("coupling.scheme", "conserving couples linear partitions without heat; "
                 "this scene has heat (use overlap or staggered)")
        if scene.model.kind == "continuum" and scene.model.prescribed:
            fail("model.prescribed", "the conserving scheme builds its interface law from "
                 "responses with the loads off, which a prescribed motion would enter (use "
                 "overlap or staggered)")
        lat = getattr(scene.model, "lattice", None)
        if lat is not None and BOND_GEOMETRIES[lat.geometry].current:
            fail("coupling.scheme", f"conserving couples linear partitions; "
                 f"model.lattice.geometry is {lat.geometry} (use linear, or staggered)")
        coarse, other = two_sides(scene, cls.name)
        parts = scene.partitions
        if (other.method, other.integrator) not in (("fem", "explicit"), ("dem", "verlet")) \
                or coarse.method != "fem":
            fail("coupling.scheme", f"conserving: the fine partition '{other.name}' must be "
                 f"fem+explicit or dem+verlet and the coarse '{coarse.name}' fem+implicit")
        if (coarse.beta, coarse.gamma) != (0.25, 0.5):
            fail(f"partitions[{parts.index(coarse)}].beta", f"conserving: the implicit "
                 f"partition '{coarse.name}' must be average acceleration (beta 0.25, "
                 f"gamma 0.5), not beta {coarse.beta:g}, gamma {coarse.gamma:g}")
        if other.method == "fem" and (other.beta, other.gamma) != (0.0, 0.5):
            fail(f"partitions[{parts.index(other)}].beta", f"conserving: the explicit "
                 f"partition '{other.name}' must be central difference (beta 0, gamma 0.5), "
                 f"not beta {other.beta:g}, gamma {other.gamma:g}")
        super().validate(scene)

    @classmethod
    def build(cls, scene, model, comm, say):
        return cls(scene, model, comm, say)

    def __init__(self, scene, mdl, comm, say=None):
        """Rank 0 (the whole model) finds the interface and plans; every rank
        gets the plan and its share of the model and builds its side's piece
        on that side's communicator."""
        P = init()
        self.comm = comm
        decided, shares = on_root(comm, plan, scene, mdl, comm.size, share=False) or (None, None)
        if comm.size > 1:
            decided = comm.bcast(decided)
            mdl = scatter_each(comm, shares)
        else:
            mdl, = shares
        del shares
        f, c = decided.f, decided.c
        self.f, self.c, self.iface, self._scene = f, c, decided.iface, scene
        self.layouts, self.sides = decided.layouts, decided.assignment
        self.owned_counts = [lay.n_owned for lay in decided.layouts]
        if say is not None and comm.size > 1:
            for line in self.sides.lines([p.name for p in scene.partitions]):
                say(line)
        comms = ranks.communicators(comm, self.sides)
        self.model = mdl
        specs = scene.partitions
        R, dt = scene.system_ratio, scene.time.dt
        self.freqs, built, error = dict(decided.freqs), {}, None
        try:
            for k in self.sides.partitions_on(comm.rank):
                m = side_model(scene, mdl, f, k)
                dist = decided.dists[k]
                piece = dist.pieces[self.sides.ranks[k].index(comm.rank)]
                kind = DemPartition if specs[k].method == "dem" else FemPartition
                built[k] = (kind(specs[k], piece, m, comms[k], "taylor" if k == f else "literal",
                                 dt, R, scene.damping, dist=dist), m)
        except SolverError as e:
            error = e
        agree(comm, error)
        self._large_sides(scene, built, comm)
        self.parts = [built[k][0] for k in sorted(built)]
        self.models = {built[k][0].name: built[k][1] for k in built}
        self.F = built[f][0] if f in built else None
        self.C = built[c][0] if c in built else None
        self.m = scene.system_ratio // specs[f].ratio
        self.T = specs[c].ratio * dt
        # interface DOFs: their positions in the interface vectors (0..n-1) and
        # the local rows of those this rank's pieces hold (F: externals, C: owned)
        gd = decided.dofs
        self.n = gd.size
        self.pf, self.rf = self._rows(self.F, gd)
        self.pc, self.rc = self._rows(self.C, gd)
        self.replay = self.F is not None and bool(self.F.damping)
        self.r0, self.G0 = np.zeros(self.n), np.zeros(self.n)
        if self.F is not None:
            if self.F.damping:
                self.F.clear_external_mass_damping()      # interface inertia is the coarse side's
            self.F.n_energy = self.F.U.size               # its elements' energy on the interface rows
        self._set_up(P)
        self.clocks = Clocks(self.parts, [p.name for p in specs], comm)

    def _large_sides(self, scene, built, comm):
        """Sides too large for the check before building: the estimate from the
        assembled operator (collective on the side's ranks), then refuse."""
        local, error = {}, None
        try:
            for part, _ in built.values():
                if self.freqs[part.name][0] is None:
                    fr, crit, problem = stability.assembled(scene, part)
                    if problem:
                        raise StabilityError(f"{problem} ({NOTE})")
                    local[part.name] = (fr, crit)
        except SolverError as e:
            error = e
        agree(comm, error)
        for chunk in (comm.allgather(local) if comm.size > 1 else [local]):
            self.freqs.update(chunk)

    @staticmethod
    def _rows(part, gdofs):
        """(positions in ``gdofs``, local rows) of the global DOFs ``gdofs`` that
        ``part``'s piece on this rank holds (none where no piece of it is here)."""
        if part is None or not part.held_dofs.size:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        held = part.held_dofs
        order = np.argsort(held)
        at = np.minimum(np.searchsorted(held[order], gdofs), held.size - 1)
        hit = held[order][at] == gdofs
        return np.flatnonzero(hit), order[at[hit]].astype(np.int64)

    # ---------------------------------------------------------------- set-up
    def _coarse_solve(self, forces):
        """K_eff^-1 E_I forces (the coarse side's acceleration per interface
        force; ``forces``: the whole interface vector, this rank's rows used;
        collective on the coarse side's ranks)."""
        self._rhs.set(0.0)
        self._rhs.getArray()[self.rc] = forces[self.pc]
        self.C.ksp.solve(self._rhs, self._sol)
        return self._sol.getArray()

    def _fine_pass(self, t0, V, loads=True):
        """The fine side's m steps from its current state with the interface on
        u_I(t_0) + s V; returns (mean reaction, last reaction) as interface
        vectors, this rank's rows filled (zero elsewhere).  The residuals are
        summed over all held rows with VecAXPY (cheaper per step than picking
        the interface rows) and the interface rows read once.  Collective on
        the fine side's ranks."""
        F, rf, pf, step, m = self.F, self.rf, self.pf, self.F.step_once, self.m
        F.V[rf], F.A[rf] = V[pf], 0.0
        racc, axpy, r = self._racc, self._racc.axpy, F.r
        racc.set(0.0)
        rows, path, values, groups = self._ld_rows, self._path, self._values, F.load_groups
        for j in range(1, m + 1):
            step(t0 + j * F.dt)             # central difference or velocity Verlet
            axpy(1.0 if j < m else 0.5, r)  # the residual at the step's new displacement
            if rows.size:
                path[j] = F.U[rows]
                values[j] = [g.val for g in groups]     # g(t_j), as the residual applied it
        if loads:
            F.steps += m
        mean, last = np.zeros(self.n), np.zeros(self.n)
        mean[pf] = (0.5 * self.r0[pf] - self._Racc[rf]) / m
        last[pf] = -F.R[rf]
        return mean, last

    def _set_up(self, P):
        """Responses to a unit interface velocity: the fine side's state S (its
        own rows on each of its ranks) and reactions (Rbar mean, Rm last), the
        coarse X_II; the interface-sized Rbar, Rm and X_II replicated on every
        rank (one allreduce), Z factored on every rank."""
        n, F, C = self.n, self.F, self.C
        Rbar, X, Rm = np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n))
        if F is not None:
            groups = F.load_groups
            self._ld_rows = np.concatenate([g.own for g in groups]) if groups else \
                np.zeros(0, np.int64)
            self._path = np.zeros((self.m + 1, self._ld_rows.size))
            self._values = np.zeros((self.m + 1, len(groups)))      # each group's g(t_j)
            self._scale = np.zeros((len(groups), self._ld_rows.size))  # group -> loaded rows
            at = 0
            for i, g in enumerate(groups):
                self._scale[i, at:at + g.own.size] = g.own_scale
                at += g.own.size
            self._ld_resp = np.zeros((self.m + 1, self._ld_rows.size, n))
            self._Racc = np.zeros(F.R.size)
            self._racc = vec_on(self._Racc, F.comm)       # F.r's layout (VecAXPY)
            saved = F.state.copy()
            cols = []
            with F.loads_off():                 # the response to V alone
                for k in range(n):
                    F.state[...] = 0.0
                    V = np.zeros(n)
                    V[k] = 1.0
                    Rbar[:, k], Rm[:, k] = self._fine_pass(0.0, V, loads=False)
                    self._ld_resp[:, :, k] = self._path
                    reached = np.flatnonzero(F.state.reshape(-1))
                    cols.append((reached, F.state.reshape(-1)[reached]))
            F.state[...] = saved
            self.S = self._response(cols, F.state.size, P)
            self._Vf = np.zeros(n)
            self._link = (P.Vec().createWithArray(self._Vf, comm=P.COMM_SELF),
                          P.Vec().createWithArray(F.state.reshape(-1), comm=P.COMM_SELF))
        if C is not None:
            self._rhs, self._sol = vec_on(np.zeros(C.n_own), C.comm), vec_on(np.zeros(C.n_own),
                                                                           C.comm)
            for k in range(n):
                e = np.zeros(n)
                e[k] = 1.0
                X[self.pc, k] = self._coarse_solve(e)[self.rc]
        self.Rbar, self.Rm, self.X_II = exact_sum(self.comm, Rbar, Rm, X)
        self.c_link = 2.0 * self._scene.partitions[self.c].beta * self.T ** 2
        self._buf = np.zeros(4 * n)
        self.zksp = None
        if n:
            Z = self.T * np.eye(n) + self.c_link * self.X_II @ self.Rbar
            self.Z = P.Mat().createDense((n, n), array=Z, comm=P.COMM_SELF)
            self.Z.assemble()
            ksp = P.KSP().create(P.COMM_SELF)
            ksp.setOperators(self.Z)
            ksp.setType("preonly")
            ksp.getPC().setType("lu")
            ksp.setUp()
            self.zksp = ksp
            self._b, self._V = self.Z.createVecs()
        self._coarse_ksp = self._coarse_solver()

    def _coarse_solver(self):
        """(ranks, KSP type, PC type) of the coarse side's solves, on every rank."""
        C = self.C
        mine = (C.comm.size, C.ksp.getType(), C.ksp.getPC().getType()) \
            if C is not None and C.layout.piece == 0 else None
        if self.comm.size == 1:
            return mine
        return next(x for x in self.comm.allgather(mine) if x is not None)

    @staticmethod
    def _response(cols, size, P):
        """The fine state's response to V as a sparse PETSc matrix (rows: this
        rank's fine state entries, columns: the interface DOFs)."""
        rows = np.concatenate([r for r, _ in cols]) if cols else np.zeros(0, np.int64)
        vals = np.concatenate([v for _, v in cols]) if cols else np.zeros(0)
        cidx = np.concatenate([np.full(r.size, k) for k, (r, _) in enumerate(cols)]) \
            if cols else np.zeros(0, np.int64)
        S = P.Mat().createAIJ((size, len(cols)), comm=P.COMM_SELF)
        S.setPreallocationCOO(rows.astype(P.IntType), cidx.astype(P.IntType))
        S.setValuesCOO(vals)
        S.assemble()
        return S

    def describe(self) -> str:
        specs = self._scene.partitions
        sides = [len(self.sides.ranks[k]) for k in (self.f, self.c)]
        ranks_, ksp, pc = self._coarse_ksp
        solves = "" if pc in DIRECT_PCS else (
            f"; coarse solves on {ranks_} ranks iterative, KSP {ksp} + PC {pc} to rtol 1e-12 "
            "(this PETSc has no parallel direct solver; -"
            f"{specs[self.c].name}_ksp_* / _pc_* options choose another)")
        return (f"energy-conserving multi-time-step coupling: {self.iface.size} interface node(s) "
                f"{self.iface.tolist()[:6]}, fine '{specs[self.f].name}' on the coarse side's "
                f"straight interface path, coarse '{specs[self.c].name}' with the fine reactions' "
                f"trapezoidal mean; {self.n}x{self.n} interface system factored once"
                + (f" on every rank; sides on {sides[0]} + {sides[1]} rank(s), one allreduce of "
                   f"4 x {self.n} values per system step" if self.comm.size > 1 else "")
                + solves + f"; stable by construction at any ratio (here {self.m})")

    # -------------------------------------------------------------- stepping
    def initialise(self, model):
        """Initial states; the coarse interface's initial acceleration takes the
        fine side's reaction (G_0 = -r_0)."""
        for part in self.parts:
            part.initialise(self.models[part.name])
        if self.F is not None:
            self._reaction()
        r0, = exact_sum(self.comm, self.r0)
        self.r0 = r0
        if self.C is not None:
            self.G0 = -r0
            self.C.A[self.rc] += self.G0[self.pc] * self.C.inverse_mass[self.rc]

    def _reaction(self):
        """r_0 on this rank's fine interface rows (collective on the fine side)."""
        F = self.F
        F.internal_force(F.u, F.r)
        self.r0 = np.zeros(self.n)
        self.r0[self.pf] = -F.R[self.rf]

    def synchronise(self):
        """The interface state from the coarse side (restarts, the step-matrix
        analysis): the fine side's interface rows and reaction, and the coarse
        side's interface force implied by its acceleration at its time."""
        C = self.C
        uv = np.zeros((2, self.n))
        if C is not None:
            uv[:, self.pc] = C.U[self.rc], C.V[self.rc]
        uv, = exact_sum(self.comm, uv)
        if self.F is not None:
            self.F.U[self.rf], self.F.V[self.rf] = uv[:, self.pf]
            self._reaction()
        if C is not None:
            C.residual(C.steps * C.dt, C.u, C.v)
            self.G0 = np.zeros(self.n)
            self.G0[self.pc] = C.mass[self.rc] * C.A[self.rc] - C.R[self.rc]

    def memory(self) -> dict:
        """The interface force G_0 (coarse side), the fine side's reaction r_0 and
        its own copy of the interface state as the last step left them, whole
        interface vectors on every rank (collective): synchronise() recovers
        them from the coarse side, equal to round-off; the checkpoint keeps
        them so a restart is bitwise."""
        G0, r0, fine = np.zeros(self.n), np.zeros(self.n), np.zeros((3, self.n))
        if self.C is not None:
            G0[self.pc] = self.G0[self.pc]
        if self.F is not None:
            r0[self.pf] = self.r0[self.pf]
            fine[:, self.pf] = self.F.state[:, self.rf]           # its own u, v, a there
        G0, r0, fine = exact_sum(self.comm, G0, r0, fine)
        return {"G0": G0, "r0": r0, "fine_interface": fine}

    def restore_memory(self, memory: dict):
        if self.C is not None and "G0" in memory:
            self.G0 = np.array(memory["G0"], dtype=float)
        if self.F is not None and "r0" in memory:
            self.r0 = np.array(memory["r0"], dtype=float)
            self.F.state[:, self.rf] = np.asarray(memory["fine_interface"])[:, self.pf]

    def step(self, t0: float):
        """Coarse free step and fine free pass (concurrent when the sides are on
        different ranks), one reduction of the interface system's right-hand
        side and the fine reactions, the interface solve (on every rank), then
        both corrections."""
        clocks, n, buf = self.clocks, self.n, self._buf
        buf[:] = 0.0
        if self.C is not None:
            clocks.part(self.C, self._coarse_free, t0 + self.T)
        if self.F is not None:
            clocks.part(self.F, self._fine_free, t0)
        if self.comm.size > 1:
            clocks.exchange(self._reduce)
        # the coarse free interface displacement, the fine start, mean and last reactions
        u_free, u_fine, rbar0, rm0 = buf[:n], buf[n:2 * n], buf[2 * n:3 * n].copy(), \
            buf[3 * n:].copy()
        V = np.zeros(n)
        if self.zksp is not None:
            self._b.getArray()[:] = u_free + (-u_fine - self.c_link * (self.X_II @ rbar0))
            self.zksp.solve(self._b, self._V)
            V = self._V.getArray().copy()
        if self.F is not None:
            clocks.part(self.F, self._fine_link, V, rm0)
        if self.C is not None:
            clocks.part(self.C, self._coarse_link, V, rbar0, rm0)

    def _reduce(self):
        from mpi4py import MPI  # lazy: importing mpi4py starts MPI; the entry point decides when
        self.comm.Allreduce(MPI.IN_PLACE, self._buf, op=MPI.SUM)

    def _coarse_free(self, t_m):
        """Predict, solve with the interface force G_m = -G_0 (Lambda = 0); the
        coarse side's free interface displacement goes into the reduction."""
        C, rc = self.C, self.rc
        C.integrator.predict(C)
        C.residual(t_m, C.ut, C.vt)
        C.R[rc] -= self.G0[self.pc]
        C.accelerate()
        self._buf[self.pc] = C.work_array("ut")[rc] + C.integrator.beta * C.dt ** 2 * C.A[rc]

    def _fine_free(self, t0):
        """The fine pass with the interface held (V = 0); its start interface
        displacement and its mean and last reactions go into the reduction.  A
        damped fine side keeps its start state for the replay
        (:meth:`_fine_link`) and dissipates nothing on this path."""
        F, n, pf = self.F, self.n, self.pf
        uF0 = F.U[self.rf].copy()
        if self._ld_rows.size:
            self._u0 = F.U[self._ld_rows]
            self._values[0] = [g.val_prev for g in F.load_groups]
        if self.replay:
            self._start = (t0, F.state.copy())
            F.stepping = False                      # no dissipation on the free path
        rbar0, rm0 = self._fine_pass(t0, np.zeros(n))
        F.stepping = True
        self._buf[n + pf] = uF0
        self._buf[2 * n + pf] = rbar0[pf]
        self._buf[3 * n + pf] = rm0[pf]

    def _fine_link(self, V, rm0):
        """The fine state plus its response to V; the next pass's first reaction.
        Damped, the fine side instead repeats its pass from the start state on
        the solved interface path: its dissipation h v.C v is quadratic in V,
        so it cannot be superposed (twice the fine side's cost)."""
        if self.replay:
            t0, start = self._start
            self.F.state[...] = start
            _, self.r0 = self._fine_pass(t0, V, loads=False)
            if self._ld_rows.size:
                self._track_work(None)
            return
        v, state = self._link
        self._Vf[:] = V
        self.S.multAdd(v, state, state)
        self.r0 = rm0 + self.Rm @ V
        if self._ld_rows.size:
            self._track_work(V)

    def _track_work(self, V):
        """The external work of the fine side's loads over its m steps, on the
        true path (free pass plus the response to V at every step), by the
        trapezoidal rule, and the load groups' memory for the next step."""
        F = self.F
        path = self._path + self._ld_resp @ V if V is not None else self._path.copy()
        path[0] = self._u0
        force = self._values @ self._scale                      # [m + 1, loaded rows]
        F.work += float(np.sum(0.5 * (force[1:] + force[:-1]) * np.diff(path, axis=0)))
        for g in F.load_groups:
            g.u_prev[:] = F.U[g.own]
            g.val_prev = g.val

    def _coarse_link(self, V, rbar0, rm0):
        C = self.C
        lam = -(rbar0 + self.Rbar @ V)
        C.A[:C.n_own] += self._coarse_solve(2.0 * lam)
        C.integrator.correct(C)
        C.after_step()
        self.G0 = 2.0 * lam - self.G0
        self.Lambda = lam                 # the interface force over the step (its mean)
        self._regauge(-(rm0 + self.Rm @ V))

    def _regauge(self, G):
        """Make the coarse interface force at t_m the fine side's reaction G = -r_m.

        The average-acceleration recursion G_m = 2 Lambda - G_0 leaves a
        free alternating part in the interface force and so in the recorded
        interface acceleration (a zig-zag of period two system steps).  It is
        a null mode: u and v depend on G_0 and a_0 only through a_0 + a_m, so
        moving G_0 by dG and a_I by dG / m_I changes no later u or v (to
        round-off).  With G = -r_m the coarse interface acceleration is
        Newton's at t_m: (coarse forces + the fine side's reaction) / m_I."""
        C, rc = self.C, self.rc
        C.A[rc] += (G - self.G0)[self.pc] * C.inverse_mass[rc]
        self.G0 = G
