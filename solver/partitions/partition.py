"""A partition: the state of its held nodes and the stepping of its integrator.

Local vectors run over the partition's *held* DOFs: owned first, then the
external layers (see :mod:`solver.coupling.overlap`).  The state is one array
``state[3, n_held_dofs]`` whose rows are displacement, velocity and
acceleration; PETSc Vecs ``u, v, a`` share that memory, so integrators use
PETSc vector operations and the exchange copies whole rows with numpy.

External-data treatments (``coupling.external``):
  taylor   external accelerations stay at their exchanged values, so external
           displacement and velocity follow x + s v + s^2/2 a (the Taylor
           predictor from the last exchange) during the sub-steps;
  layers   one external layer per sub-step, integrated with the partition's
           scheme (the outer layers degrade but never reach the boundary);
  literal  one layer integrated with the partition's own scheme (seed 000);
  prescribed  (set by the staggered scheme for its implicit partition) the
           external (u, v, a) at the new time come from the other partition:
           only owned rows are solved and corrected.

Subclasses (:mod:`solver.partitions.fem`, :mod:`solver.partitions.dem`) build the partition's force
object (:mod:`solver.partitions.force`); the partition only asks it for the internal
force, the strain energy and the tangent.
"""
from __future__ import annotations

import numpy as np

from solver.model.arrays import dof_masses
from solver.partitions import integrators
from solver.petscutil import vec_on
from solver.partitions.distribute import whole
from solver.partitions.thermal import ThermalForce
from solver.partitions.assembly import default_type, matrix


class LoadGroup:
    """Loaded DOFs sharing one time function g: f = g(t) * scale at ``idx``;
    ``own`` marks the owned ones (their external work is this partition's).
    A single DOF takes a scalar path (no numpy call overhead per step)."""

    def __init__(self, key, at, idx, scale, own):
        self.key = key              # index of the group's first load in the model
        self.at = at
        self.idx = np.asarray(idx, dtype=np.int64)
        self.scale = np.asarray(scale, dtype=float)
        own = np.asarray(own, dtype=bool)
        self.own, self.own_scale = self.idx[own], self.scale[own]
        self.single = self.idx.size == 1
        self.i0, self.s0 = int(self.idx[0]), float(self.scale[0])
        self.val = self.val_prev = 0.0
        self.u_prev = np.zeros(self.own.size)

    def apply(self, R, t):
        """R += f(t); remembers g(t) for the work."""
        v = self.val = self.at(t)
        if self.single:
            R[self.i0] += v * self.s0
        else:
            R[self.idx] += v * self.scale          # DOFs are distinct within a group

    def remember(self, U):
        self.val_prev = self.val
        self.u_prev[:] = U[self.own]

    def work_increment(self, U) -> float:
        """1/2 (f_n + f_n+1) . (u_n+1 - u_n) over the owned DOFs, then remember."""
        if self.single:
            u = float(U[self.i0])
            w = 0.5 * (self.val_prev + self.val) * self.s0 * (u - self.u_prev[0])
            self.u_prev[0] = u
        else:
            u = U[self.own]
            w = 0.5 * (self.val_prev + self.val) * float(np.dot(self.own_scale, u - self.u_prev))
            self.u_prev[:] = u
        self.val_prev = self.val
        return w


class Partition:
    method = "?"
    failed = False          # set by the scheme when stepping raised; it then stops stepping

    def __init__(self, spec, layout, model, comm, treatment: str, base_dt: float,
                 system_ratio: int, damping=None, dist=None, graph=None):
        self.spec = spec
        # the partition over the ranks of ``comm``; ``layout`` is this rank's piece
        self.dist = dist if dist is not None else whole(layout, model.n_nodes)
        self.graph = graph          # node adjacency (indptr, indices): preallocation
        self.name = spec.name
        self.prefix = f"{spec.name}_"
        self.layout = layout = self.dist.pieces[0] if dist is None else layout
        self.comm = comm
        self.dt = spec.ratio * base_dt
        self.n_sub = system_ratio // spec.ratio
        self.integrator = integrators.make(spec)
        dm = self.dofmap = model.dofmap
        self.dof = dm.block                     # DOFs per node when all nodes agree, else None
        held = layout.held
        self.held_dofs = dm.dofs(held)
        self.starts = dm.starts(held)           # each held node's first local DOF
        self.n_own = dm.count(layout.owned)
        self.n_energy = self.n_own              # rows whose 1/2 u_i (K u)_i is this partition's
        n = self.held_dofs.size
        # this rank's rows in the partition's distributed DOF numbering
        self.first = sum(dm.count(pc.held) for pc in self.dist.pieces[:layout.piece])
        self.n_global = dm.count(self.dist.layout.held)
        self.state = np.zeros((3, n))
        self.U, self.V, self.A = self.state
        self.u, self.v, self.a = (vec_on(x, comm) for x in (self.U, self.V, self.A))
        self.R = np.zeros(n)
        self.r = vec_on(self.R, comm)
        self._work = {name: np.zeros(n) for name in self.integrator.work}
        for name, arr in self._work.items():
            setattr(self, name, vec_on(arr, comm))
        self.mass = dof_masses(model, held)
        self._minv = 1.0 / self.mass
        self.fixed_dofs = model.fixed[self.held_dofs]
        self._minv[self.fixed_dofs] = 0.0                     # fixed DOFs never accelerate
        self.minv = vec_on(self._minv, comm)
        # taylor / prescribed: the acceleration solve covers the owned DOFs only,
        # so external accelerations keep their exchanged values
        self.frozen = treatment in ("taylor", "prescribed")
        m = self.n_own if self.frozen else n
        self._solve = (vec_on(self.A[:m], comm), vec_on(self.R[:m], comm),
                       vec_on(self._minv[:m], comm))
        self._views = list(self._solve)
        self.corrected = (self.u, self.v, self.a, *(getattr(self, w) for w in self.integrator.work))
        if treatment == "prescribed" and self.integrator.work:
            owned = [vec_on(x[:self.n_own], comm) for x in
                     (self.U, self.V, self.A, self._work["ut"], self._work["vt"])]
            self.corrected = tuple(owned)
            self._views += owned
        self._setup_loads(model, layout)
        self.damping = damping if damping is not None and damping.active else None
        if self.damping and self.integrator.name == "explicit":
            # explicit Newmark: (M + gamma h alpha M) a = f - K u~ - C v~ keeps the
            # mass-proportional part second order and the solve diagonal
            self._minv /= 1.0 + self.integrator.gamma * self.dt * self.damping.alpha
        if self.damping:
            # r = f - K u - beta K v - alpha M v: work Vecs made only when damped
            self._am = self.damping.alpha * self.mass
            self.am_v = vec_on(np.zeros(n), comm)
            self.alpha_m = vec_on(self._am, comm)
        for name in ("u", "v", "a", "r", "minv", *self.integrator.work):
            getattr(self, name).setOptionsPrefix(self.prefix)
        self.force = self.build_force(model, layout)
        self._internal = self.force.internal
        self._viscous = getattr(self.force, "viscous", None)
        self.thermal = None
        heat = getattr(model, "heat", None)
        if heat is not None and heat.spec.expansion > 0 and self.force.blocks:
            self.thermal = ThermalForce(self, self.force.blocks, model.points, heat.n_model,
                                        heat.spec)
            self.built.append("thermal forces alpha G dT of the elements (G: "
                              f"{self.held_dofs.size}x{heat.n_model})")
        self._step = self.integrator.bind(self)
        self.steps = 0
        self.wall = 0.0
        # the energy audit: what Rayleigh damping and contact dashpots dissipate,
        # h v.C v per step at the velocity the residual uses (energy/dissipated)
        self.track_dissipation = not self.force.linear or bool(self.damping)
        self.dissipated = 0.0
        self.stepping = False

    # ------------------------------------------------------------------ set-up
    def build_force(self, model, layout):
        raise NotImplementedError

    @property
    def Kneg(self):
        """The tangent dF/du (-K for linear partitions) as a PETSc Mat."""
        return self.force.tangent()

    def operator(self, block_sets, scale=1.0, diagonal=None, solved=False):
        """This rank's rows of a matrix over the partition's held DOFs from
        element block sets (global node ids; see :mod:`solver.partitions.assembly`)."""
        return matrix(lambda: block_sets, self.dist.number, self.layout.n_held, self.dist.n_held,
                      self.layout.start, self.dofmap, self.comm, self.prefix, scale=scale,
                      diagonal=diagonal, mat_type=default_type(self.dof, solved), graph=self.graph)

    def whole_held(self):
        """Held nodes of the whole partition (all its pieces)."""
        return self.dist.layout.held

    def _setup_loads(self, model, layout):
        """Group the held loaded DOFs by time function: one numpy update per group
        and step (a traction on a face is one group), not a Python loop per DOF."""
        nodes, comps = model.dofmap.node_of([l.dof for l in model.loads])
        local = layout.local(nodes) if nodes.size else nodes
        groups: dict[int, tuple] = {}
        first: dict[int, int] = {}
        for i, load in enumerate(model.loads):
            first.setdefault(id(load.function), i)
        for load, loc, comp in zip(model.loads, local, comps):
            if loc < 0:
                continue
            _, at, idx, scale, own = groups.setdefault(
                id(load.function), (first[id(load.function)], load.function.at, [], [], []))
            idx.append(int(self.starts[loc] + comp))
            scale.append(load.scale)
            own.append(loc < layout.n_owned)
        self._loads = [LoadGroup(*g) for g in groups.values()]
        self._owned_loads = [g for g in self._loads if g.own.size]
        self.work = 0.0

    def describe(self) -> str:
        lay = self.layout
        ext = " + ".join(str(l.size) for l in lay.layers) or "0"
        piece = f" piece {lay.piece + 1}/{lay.pieces}" if lay.pieces > 1 else ""
        return (f"{self.name}{piece}: {self.method}, {self.integrator.describe()}; step {self.dt:.3e} s "
                f"x {self.n_sub} per system step; nodes: {lay.n_owned} owned (boundary "
                f"{_ids(lay.boundary)}, interior {lay.interior.size}), external {ext} in "
                f"{len(lay.layers)} layer(s) {_ids(lay.external)}")

    # ---------------------------------------------------------------- physics
    def residual(self, t, u, v):
        """r = f(t) - K u - C v, C = alpha M + beta K (undamped partitions ignore v).
        A nonlinear force is evaluated at u (at time t, when bonds break), its
        stiffness-proportional damping with the tangent at rest."""
        if not self.force.linear:
            self.force.now = t
            self._internal(u, self.r)
            if v is not None and self._viscous is not None:            # contact dashpots
                power = self._viscous(v, self.r)
                if self.track_dissipation and self.stepping:
                    self.dissipated += self.dt * power
            if self.damping and v is not None:
                self.force.tangent().mult(v, self.am_v)            # -K0 v
                self.r.axpy(self.damping.beta, self.am_v)
                self._dissipate(v, -self.damping.beta)
                self.am_v.pointwiseMult(self.alpha_m, v)
                self.r.axpy(-1.0, self.am_v)
                self._dissipate(v, 1.0)
        elif self.damping and v is not None:
            if self.damping.beta:                    # -K u - beta K v, beta v.K v dissipated
                self._internal(v, self.am_v)
                self._dissipate(v, -self.damping.beta)
                self._internal(u, self.r)
                self.r.axpy(self.damping.beta, self.am_v)
            else:
                self._internal(u, self.r)
            self.am_v.pointwiseMult(self.alpha_m, v)
            self.r.axpy(-1.0, self.am_v)
            self._dissipate(v, 1.0)
        else:
            self._internal(u, self.r)
        for group in self._loads:
            group.apply(self.R, t)
        if self.thermal is not None:
            self.R += self.thermal.force

    def set_temperature(self, T_node, count=True):
        """Model-node temperatures (``heat``): thermal forces, bond rest lengths and
        strengths follow; the rest lengths' work (the strain energy they change)
        goes into the external work unless not ``count``."""
        if self.thermal is not None:
            self.thermal.set_temperature(T_node)
        if hasattr(self.force, "set_temperature"):
            self.work += self.force.set_temperature(T_node, count)

    def track_thermal_work(self, count=True):
        """After a system step: the thermal forces' work over it (external work)."""
        if self.thermal is not None:
            self.work += self.thermal.track(count)

    def _dissipate(self, v, scale):
        """dissipated += h scale v . am_v over the owned DOFs (the damping power
        of the step, at the velocity the residual uses), once stepping."""
        if self.track_dissipation and self.stepping:
            n = self.n_own
            self.dissipated += self.dt * scale * float(
                np.dot(v.getArray(readonly=True)[:n], self.am_v.getArray(readonly=True)[:n]))

    def accelerate(self):
        """a = M^-1 r; under the taylor treatment external a keeps its exchanged value."""
        a, r, minv = self._solve
        a.pointwiseMult(r, minv)

    def initialise(self, model):
        """Initial state and a_0 = M^-1 (f(0) - K u_0) on the held DOFs."""
        self.U[:] = model.u0[self.held_dofs]
        self.V[:] = model.v0[self.held_dofs]
        self.residual(0.0, self.u, self.v)
        self.a.pointwiseMult(self.r, self.minv)
        self._remember_loads()
        self.stepping = True

    def load_memory(self) -> dict:
        """{load key: last load value} of the owned load groups (checkpoint state)."""
        return {g.key: g.val_prev for g in self._owned_loads}

    def restore_load_memory(self, values: dict):
        for group in self._loads:
            if group.key in values:
                group.val = group.val_prev = values[group.key]
        for group in self._owned_loads:
            group.u_prev[:] = self.U[group.own]

    def _remember_loads(self):
        for group in self._owned_loads:
            group.remember(self.U)

    def after_step(self):
        """Bookkeeping after every completed step: step count and external work."""
        self.steps += 1
        self._track_work()

    def _track_work(self):
        """W += 1/2 (f_n + f_n+1) . (u_n+1 - u_n) over the owned loaded DOFs (the
        work the trapezoidal rule balances exactly)."""
        for group in self._owned_loads:
            self.work += group.work_increment(self.U)

    def advance(self, t0: float):
        """One system step: ``n_sub`` steps of size ``dt`` from time ``t0``."""
        step, h = self._step, self.dt
        if self._owned_loads:
            track = self._track_work
            for k in range(1, self.n_sub + 1):
                step(t0 + k * h)
                track()
        else:
            for k in range(1, self.n_sub + 1):
                step(t0 + k * h)
        self.steps += self.n_sub

    def energies(self):
        """(kinetic, strain, external work, dissipated by damping) of the owned DOFs.

        Strain energy is 1/2 sum_owned u_i (K u)_i, which sums to 1/2 u^T K u
        over all partitions because owned rows of a partition's K are complete.
        """
        n = self.n_own
        kinetic = 0.5 * float(np.dot(self.mass[:n], self.V[:n] ** 2))
        return kinetic, self.force.energy(self), self.work, self.dissipated

    def work_array(self, name: str) -> np.ndarray:
        """numpy view of an integrator work Vec (``ut``, ``vt`` for Newmark)."""
        return self._work[name]

    def local_index(self, node: int, component: int) -> int:
        loc = int(self.layout.local(np.array([node]))[0])
        return int(self.starts[loc]) + component

    def destroy(self):
        for name in ("u", "v", "a", "r", "minv", *self.integrator.work):
            getattr(self, name).destroy()
        self.force.destroy()
        if self.thermal is not None:
            self.thermal.destroy()
        for vec in self._views:
            vec.destroy()
        if self.damping:
            for vec in (self.am_v, self.alpha_m):
                vec.destroy()


def _ids(nodes, limit=6) -> str:
    nodes = list(map(int, nodes))
    if len(nodes) <= limit:
        return str(nodes)
    return f"[{', '.join(map(str, nodes[:limit]))}, ... {len(nodes)} nodes]"
