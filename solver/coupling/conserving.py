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
tracked on its true path); 1 or 2 ranks.
"""
from __future__ import annotations

import numpy as np

from solver.collective import agree, on_root
from solver.model.layout import Layout
from solver.coupling.scheme import two_sides
from solver.coupling.system_step import Clocks
from solver.coupling.gc import OwnSides
from solver.errors import LaunchError, SceneError, SolverError
from solver.laws import BOND_GEOMETRIES
from solver.partitions import integrators, stability
from solver.model.cell_blocks import kept
from solver.partitions.dem import DemPartition
from solver.partitions.fem import FemPartition
from solver.petscutil import init
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


def held_nodes(scene, k, f, iface):
    owned = np.unique(np.asarray(scene.partitions[k].nodes, dtype=np.int64))
    return owned, (np.concatenate([owned, iface]) if k == f else owned)


class Conserving(OwnSides):
    name = "conserving"
    summary = ("energy-conserving multi-time-step coupling of an explicit fem or dem partition "
               "and an implicit one at any ratio (stable by construction; no heat, linear bonds; "
               "docs/conserving.md, 1 or 2 ranks)")
    about = ("energy-conserving multi-time-step coupling (docs/conserving.md): the fine "
             "side follows the coarse side's straight displacement path on a shared "
             "interface, and a discrete energy is conserved to round-off")
    supports = ("network and continuum models without heat and with linear bonds; exactly "
                "two partitions on a node-matching interface: fem+implicit (average "
                "acceleration: beta 0.25, gamma 0.5) with the largest ratio and fem+explicit "
                "(central difference: beta 0, gamma 0.5) or dem+verlet; 1 or 2 ranks (one per "
                "side)")
    limit = ("stable at any ratio whenever each side is: the fine side's own explicit "
             "limit with the interface nodes at full mass; the coarse side none")
    max_ranks = 2

    @classmethod
    def validate(cls, scene):
        if scene.heat is not None:
            fail("coupling.scheme", "conserving couples linear partitions without heat; "
                 "this scene has heat (use overlap or staggered)")
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
    def check_launch(cls, scene, size: int):
        """At most 2 ranks, each side on one."""
        super().check_launch(scene, size)
        for k, p in enumerate(scene.partitions):
            if p.ranks is not None and p.ranks != 1:
                raise LaunchError(f"partitions[{k}].ranks: coupling.scheme conserving runs each "
                                  "side on one rank")

    @classmethod
    def build(cls, scene, model, comm, say):
        return cls(scene, model, comm)

    def __init__(self, scene, mdl, comm):
        """Rank 0 (the whole model) finds the interface; on 2 ranks partition k
        runs on rank k and rank 1 gets only its side's share of the model."""
        P = init()
        self.comm = comm
        f, c, iface = on_root(comm, interface, scene, mdl)
        self.f, self.c, self.iface, self._scene = f, c, iface, scene
        local = [f, c] if comm.size == 1 else [comm.rank]
        if comm.size > 1:
            share = None
            if comm.rank == 0:
                share = mdl.share(held_nodes(scene, 1, f, iface)[1])
                comm.send(share, dest=1)
            else:
                mdl = comm.recv(source=0)
        self.model = mdl
        specs = scene.partitions
        R, dt = scene.system_ratio, scene.time.dt
        self.freqs, built, error = {}, {}, None
        try:
            for k in local:
                m = side_model(scene, mdl, f, k)
                lay = self.layout(k)
                kind = DemPartition if specs[k].method == "dem" else FemPartition
                part, self.freqs[specs[k].name] = stability.side(
                    scene, specs[k], m, lay.held,
                    lambda: kind(specs[k], lay, m, P.COMM_SELF, "taylor" if k == f else "literal",
                                 dt, R, scene.damping),
                    "conserving scheme: the fine side with its interface nodes at full mass")
                built[k] = (part, m)
        except SolverError as e:
            error = e
        agree(comm, error)
        if comm.size > 1:
            for chunk in comm.allgather(self.freqs):
                self.freqs.update(chunk)
        self.parts = [built[k][0] for k in sorted(built)]
        self.models = {built[k][0].name: built[k][1] for k in built}
        self.F = built[f][0] if f in built else None
        self.C = built[c][0] if c in built else None
        self.m = scene.system_ratio // specs[f].ratio
        self.T = specs[c].ratio * dt
        # interface DOFs: the free DOFs of the interface nodes, as rows of F
        # (externals) and of C
        dm = mdl.dofmap
        gd = dm.dofs(iface)
        gd = gd[~mdl.fixed[gd]]
        self.n = gd.size
        self.rf = self._rows(self.F, gd)
        self.rc = self._rows(self.C, gd)
        self.replay = self.F is not None and bool(self.F.damping)
        if self.F is not None:
            if self.F.damping:
                self.F.clear_external_mass_damping()      # interface inertia is the coarse side's
            self.F.n_energy = self.F.U.size               # its elements' energy on the interface rows
            self.r0 = np.zeros(self.n)
        if self.C is not None:
            self.G0 = np.zeros(self.n)
        self._set_up(P)
        self.clocks = Clocks(self.parts, [p.name for p in specs], comm)
        self.layouts = [self.layout(k) for k in range(2)]

    def layout(self, k):
        owned = held_nodes(self._scene, k, self.f, self.iface)[0]
        empty = np.zeros(0, dtype=np.int64)
        if k == self.f:
            return Layout(self._scene.partitions[k].name, k, owned, empty, owned, (self.iface,),
                          np.full(self.iface.size, self.c, dtype=np.int64))
        return Layout(self._scene.partitions[k].name, k, owned, empty, owned, (), empty)

    @staticmethod
    def _rows(part, gdofs):
        """Local rows of global DOFs ``gdofs`` in ``part`` (None: not on this rank)."""
        if part is None:
            return None
        order = np.argsort(part.held_dofs)
        return order[np.searchsorted(part.held_dofs[order], gdofs)].astype(np.int64)

    def _owner(self, k):
        """The rank of partition k."""
        return 0 if self.comm.size == 1 else k

    # ---------------------------------------------------------------- set-up
    def _coarse_solve(self, forces):
        """K_eff^-1 E_I forces (the coarse side's acceleration per interface force)."""
        self._rhs.set(0.0)
        self._rhs.getArray()[self.rc] = forces
        self.C.ksp.solve(self._rhs, self._sol)
        return self._sol.getArray()

    def _fine_pass(self, t0, V, loads=True):
        """The fine side's m steps from its current state with the interface on
        u_I(t_0) + s V; returns (mean reaction, last reaction).  The residuals
        are summed over all held rows with VecAXPY (cheaper per step than
        picking the interface rows) and the interface rows read once."""
        F, rf, step, m = self.F, self.rf, self.F.step_once, self.m
        F.V[rf], F.A[rf] = V, 0.0
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
        last = -F.R[rf]
        return (0.5 * self.r0 - self._Racc[rf]) / m, last

    def _set_up(self, P):
        """Responses to a unit interface velocity: the fine side's state S and
        reactions (Rbar mean, Rm last) on the fine rank, the coarse X_II on the
        coarse rank; both replicated, Z factored on every rank."""
        n, F, C = self.n, self.F, self.C
        Rbar, X, self.Rm = np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n))
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
            self._racc = P.Vec().createWithArray(self._Racc, comm=P.COMM_SELF)
            saved = F.state.copy()
            cols = []
            with F.loads_off():                 # the response to V alone
                for k in range(n):
                    F.state[...] = 0.0
                    V = np.zeros(n)
                    V[k] = 1.0
                    Rbar[:, k], self.Rm[:, k] = self._fine_pass(0.0, V, loads=False)
                    self._ld_resp[:, :, k] = self._path
                    reached = np.flatnonzero(F.state.reshape(-1))
                    cols.append((reached, F.state.reshape(-1)[reached]))
            F.state[...] = saved
            self.S = self._response(cols, F.state.size, P)
            self._Vf = np.zeros(n)
            self._link = (P.Vec().createWithArray(self._Vf, comm=P.COMM_SELF),
                          P.Vec().createWithArray(F.state.reshape(-1), comm=P.COMM_SELF))
        if C is not None:
            self._rhs, self._sol = P.Vec().createSeq(C.n_own), P.Vec().createSeq(C.n_own)
            for k in range(n):
                e = np.zeros(n)
                e[k] = 1.0
                X[:, k] = self._coarse_solve(e)[self.rc]
        if self.comm.size > 1:
            self.comm.Bcast(Rbar, root=self._owner(self.f))
            self.comm.Bcast(self.Rm, root=self._owner(self.f))
            self.comm.Bcast(X, root=self._owner(self.c))
        self.Rbar, self.X_II = Rbar, X
        self.c_link = 2.0 * self._scene.partitions[self.c].beta * self.T ** 2
        self._buf = np.zeros(3 * n)
        self.zksp = None
        if n:
            Z = self.T * np.eye(n) + self.c_link * X @ Rbar
            self.Z = P.Mat().createDense((n, n), array=Z, comm=P.COMM_SELF)
            self.Z.assemble()
            ksp = P.KSP().create(P.COMM_SELF)
            ksp.setOperators(self.Z)
            ksp.setType("preonly")
            ksp.getPC().setType("lu")
            ksp.setUp()
            self.zksp = ksp
            self._b, self._V = self.Z.createVecs()

    @staticmethod
    def _response(cols, size, P):
        """The fine state's response to V as a sparse PETSc matrix (rows: the
        fine state's entries, columns: the interface DOFs)."""
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
        return (f"energy-conserving multi-time-step coupling: {self.iface.size} interface node(s) "
                f"{self.iface.tolist()[:6]}, fine '{specs[self.f].name}' on the coarse side's "
                f"straight interface path, coarse '{specs[self.c].name}' with the fine reactions' "
                f"trapezoidal mean; {self.n}x{self.n} interface system factored once"
                + (f", one allreduce of 3 x {self.n} values per system step"
                   if self.comm.size > 1 else "")
                + f"; stable by construction at any ratio (here {self.m})")

    # -------------------------------------------------------------- stepping
    def initialise(self, model):
        """Initial states; the coarse interface's initial acceleration takes the
        fine side's reaction (G_0 = -r_0)."""
        for part in self.parts:
            part.initialise(self.models[part.name])
        if self.F is not None:
            self._reaction()
        r0 = self.r0 if self.F is not None else np.zeros(self.n)
        if self.comm.size > 1:
            self.comm.Bcast(r0, root=self._owner(self.f))
        if self.C is not None:
            self.G0 = -r0
            self.C.A[self.rc] += self.G0 * self.C.inverse_mass[self.rc]

    def _reaction(self):
        F = self.F
        F.internal_force(F.u, F.r)
        self.r0 = -F.R[self.rf]

    def synchronise(self):
        """The interface state from the coarse side (restarts, the step-matrix
        analysis): the fine side's interface rows and reaction, and the coarse
        side's interface force implied by its acceleration at its time."""
        C = self.C
        uv = np.zeros((2, self.n))
        if C is not None:
            uv[:] = C.U[self.rc], C.V[self.rc]
        if self.comm.size > 1:
            self.comm.Bcast(uv, root=self._owner(self.c))
        if self.F is not None:
            self.F.U[self.rf], self.F.V[self.rf] = uv
            self._reaction()
        if C is not None:
            C.residual(C.steps * C.dt, C.u, C.v)
            self.G0 = C.mass[self.rc] * C.A[self.rc] - C.R[self.rc]

    def memory(self) -> dict:
        """The interface force G_0 (coarse side), the fine side's reaction r_0 and
        its own copy of the interface state as the last step left them:
        synchronise() recovers them from the coarse side, equal to round-off;
        the checkpoint keeps them so a restart is bitwise."""
        out = {}
        if self.C is not None:
            out["G0"] = np.array(self.G0, dtype=float)
        if self.F is not None:
            out["r0"] = np.array(self.r0, dtype=float)
            out["fine_interface"] = self.F.state[:, self.rf].copy()   # its own u, v, a there
        return out

    def restore_memory(self, memory: dict):
        if self.C is not None and "G0" in memory:
            self.G0 = np.array(memory["G0"], dtype=float)
        if self.F is not None and "r0" in memory:
            self.r0 = np.array(memory["r0"], dtype=float)
            self.F.state[:, self.rf] = memory["fine_interface"]

    def step(self, t0: float):
        """Coarse free step and fine free pass (concurrent on 2 ranks), one
        reduction of the interface system's right-hand side and the fine mean
        reaction, the interface solve (on every rank), then both corrections."""
        clocks, n, buf = self.clocks, self.n, self._buf
        buf[:] = 0.0
        if self.C is not None:
            clocks.part(self.C, self._coarse_free, t0 + self.T)
        if self.F is not None:
            clocks.part(self.F, self._fine_free, t0)
        if self.comm.size > 1:
            clocks.exchange(self._reduce)
        V = np.zeros(n)
        if self.zksp is not None:
            self._b.getArray()[:] = buf[:n]
            self.zksp.solve(self._b, self._V)
            V = self._V.getArray().copy()
        if self.F is not None:
            clocks.part(self.F, self._fine_link, V)
        if self.C is not None:
            clocks.part(self.C, self._coarse_link, V, buf[n:2 * n].copy(), buf[2 * n:].copy())

    def _reduce(self):
        from mpi4py import MPI  # lazy: importing mpi4py starts MPI; the entry point decides when
        self.comm.Allreduce(MPI.IN_PLACE, self._buf, op=MPI.SUM)

    def _coarse_free(self, t_m):
        """Predict, solve with the interface force G_m = -G_0 (Lambda = 0); the
        coarse side's free interface displacement goes into the reduction."""
        C, rc = self.C, self.rc
        C.integrator.predict(C)
        C.residual(t_m, C.ut, C.vt)
        C.R[rc] -= self.G0
        C.accelerate()
        self._buf[:self.n] = C.work_array("ut")[rc] + C.integrator.beta * C.dt ** 2 * C.A[rc]

    def _fine_free(self, t0):
        """The fine pass with the interface held (V = 0); its share of the
        interface system's right-hand side and its mean reaction.  A damped
        fine side keeps its start state for the replay (:meth:`_fine_link`)
        and dissipates nothing on this path."""
        F, n = self.F, self.n
        uF0 = F.U[self.rf].copy()
        if self._ld_rows.size:
            self._u0 = F.U[self._ld_rows]
            self._values[0] = [g.val_prev for g in F.load_groups]
        if self.replay:
            self._start = (t0, F.state.copy())
            F.stepping = False                      # no dissipation on the free path
        rbar0, self._rm0 = self._fine_pass(t0, 0.0)
        F.stepping = True
        self._buf[:n] += -uF0 - self.c_link * (self.X_II @ rbar0)
        self._buf[n:2 * n] = rbar0
        self._buf[2 * n:] = self._rm0

    def _fine_link(self, V):
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
        self.r0 = self._rm0 + self.Rm @ V
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
        C.A[rc] += (G - self.G0) * C.inverse_mass[rc]
        self.G0 = G
