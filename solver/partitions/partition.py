"""A partition: the state of its held nodes and the stepping of its integrator.

Local vectors run over the partition's *held* DOFs: owned first, then the
external layers (see :mod:`solver.model.layout`).  The state is one array
``state[3, n_held_dofs]`` whose rows are displacement, velocity and
acceleration; PETSc Vecs ``u, v, a`` share that memory, so integrators use
PETSc vector operations and the exchange copies whole rows with numpy.

External-data treatments (``coupling.external``):
  taylor   external accelerations stay at their exchanged values, so external
           displacement and velocity follow x + s v + s^2/2 a (the Taylor
           predictor from the last exchange) during the sub-steps;
  layers   one external layer per sub-step, integrated with the partition's
           scheme (the outer layers degrade but never reach the boundary);
  literal  one layer integrated with the partition's own scheme (Li et al. 2023);
  prescribed  (set by the staggered scheme for its implicit partition) the
           external (u, v, a) at the new time come from the other partition:
           only owned rows are solved and corrected.

Subclasses (:mod:`solver.partitions.fem`, :mod:`solver.partitions.dem`) build the partition's force
object (:mod:`solver.partitions.force`); the partition only asks it for the internal
force, the strain energy and the tangent.

A partition is composed of small parts (docs/dev/partition.md):
  vectors  :class:`~solver.partitions.state.State`      state [3, n], R, the integrator's work Vecs
  masses   :class:`~solver.partitions.mass.LumpedMass`   mass, its inverse (0 on fixed DOFs), minv
  loads    :class:`~solver.partitions.loads.Loads`       load groups, external work, their memory
  damping  :class:`~solver.partitions.damping.Damping`   Rayleigh terms (None when undamped)
  audit    :class:`~solver.partitions.audit.EnergyAudit` what damping and dashpots dissipate
  thermal  :class:`~solver.partitions.thermal.ThermalForce` (None without thermal expansion)
  motion   :class:`~solver.partitions.motion.Motions` (None without prescribed motion)
  force    :mod:`solver.partitions.force`                internal force, energy, tangent
The names other modules use (``part.U``, ``part.state``, ``part.work``,
``part.dissipated``, ``part.mass``, ...) are properties on these parts.

What a coupling scheme may use beyond the state: ``step_once(t)`` (one step of
the integrator to time t), ``internal_force(u, out)``, ``residual``,
``accelerate``, ``after_step``, ``with loads_off():``, ``load_groups`` (the
owned groups), ``inverse_mass`` and ``clear_external_mass_damping()``.
"""
from __future__ import annotations

from contextlib import contextmanager
from functools import partial
from operator import attrgetter

import numpy as np

from solver.partitions import integrators
from solver.partitions.audit import EnergyAudit
from solver.partitions.damping import Damping
from solver.partitions.loads import Loads
from solver.partitions.mass import LumpedMass
from solver.partitions.motion import Motions
from solver.partitions.state import State
from solver.petscutil import vec_on
from solver.partitions.distribute import whole
from solver.partitions.thermal import ThermalForce
from solver.partitions.assembly import default_type, matrix, rows_of


def _forward(part: str, name: str, doc: str = "", settable: bool = False):
    """A property of Partition that is attribute ``name`` of its part ``part``."""
    get = attrgetter(f"{part}.{name}")           # (C speed: the state is read every step)

    def set_(self, value):
        setattr(getattr(self, part), name, value)
    return property(get, set_ if settable else None, doc=doc or f"``{part}.{name}``")


def _work_vec(name):
    def get(self):
        try:
            return self.vectors.vecs[name]
        except KeyError:
            raise AttributeError(f"{self.integrator.name} integrators have no work Vec {name}") \
                from None
    return property(get, doc=f"the integrator work Vec {name} (Newmark)")


class Partition:
    method = "?"
    failed = False          # set by the scheme when stepping raised; it then stops stepping

    state = _forward("vectors", "state", "[3, n_held_dofs]: rows U, V, A")
    U = _forward("vectors", "U")
    V = _forward("vectors", "V")
    A = _forward("vectors", "A")
    u = _forward("vectors", "u")
    v = _forward("vectors", "v")
    a = _forward("vectors", "a")
    R = _forward("vectors", "R")
    r = _forward("vectors", "r")
    mass = _forward("masses", "mass", "[n_held_dofs] lumped mass")
    inverse_mass = _forward("masses", "inverse", "[n_held_dofs] the diagonal solve's M^-1 "
                            "(0 on fixed DOFs)")
    minv = _forward("masses", "minv")
    fixed_dofs = _forward("masses", "fixed")
    work = _forward("loads", "work", "external work of the owned loads (and thermal)", True)
    dissipated = _forward("audit", "dissipated", "energy dissipated so far", True)
    stepping = _forward("audit", "stepping", "the audit counts (False: a pass not the run's)",
                        True)
    track_dissipation = _forward("audit", "track")
    load_groups = _forward("loads", "owned", "the owned load groups (their work is this "
                           "partition's)")
    ut = _work_vec("ut")
    vt = _work_vec("vt")

    def __init__(self, spec, layout, model, comm, treatment: str, base_dt: float,
                 system_ratio: int, damping=None, dist=None):
        self.spec = spec
        # the partition over the ranks of ``comm``; ``layout`` is this rank's piece
        self.dist = dist if dist is not None else whole(layout, model.n_nodes)
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
        self.first, self.n_global = self.dist.dofs(layout.piece, dm)
        self.vectors = State(n, comm, self.integrator.work, self.prefix)
        damped = damping is not None and damping.active
        # explicit Newmark: (M + gamma h alpha M) a = f - K u~ - C v~ keeps the
        # mass-proportional part second order and the solve diagonal
        factor = self.integrator.mass_damping_factor(self.dt, damping.alpha) if damped else 1.0
        self.masses = LumpedMass(model, held, self.held_dofs, comm, factor, self.prefix)
        # taylor / prescribed: the acceleration solve covers the owned DOFs only,
        # so external accelerations keep their exchanged values
        self.frozen = treatment in ("taylor", "prescribed")
        m = self.n_own if self.frozen else n
        self._solve = (vec_on(self.A[:m], comm), vec_on(self.R[:m], comm),
                       vec_on(self.inverse_mass[:m], comm))
        self._views = list(self._solve)
        self.corrected = (self.u, self.v, self.a, *self.vectors.vecs.values())
        if treatment == "prescribed" and self.integrator.work:
            work = self.vectors.work
            owned = [vec_on(x[:self.n_own], comm) for x in
                     (self.U, self.V, self.A, work["ut"], work["vt"])]
            self.corrected = tuple(owned)
            self._views += owned
        self.loads = Loads.of(model, layout, self.starts, self.mass)
        self.motion = Motions(model.motions, self.held_dofs, self.n_own,
                              self.mass, self.vectors) or None
        moving = self.motion is not None           # on any piece of the partition:
        self._moving = bool(comm.allreduce(int(moving))) if comm.size > 1 else moving
        self._shift = self.integrator.reaction_shift(
            self.dt, damping.beta if damped else 0.0) if self._moving else 0.0
        # r = f - K u - beta K v - alpha M v: its terms and work Vecs only when damped
        self.damping = Damping.of(damping, self.mass, comm)
        self.built = []                         # what was built, for the log (subclasses add)
        self.force = self.build_force(model, layout)
        self.internal_force = self.force.internal     # internal_force(u, out): out = f_int(u)
        # the prescribed rows' reaction at the step's final state, r + c (-K a'): the
        # tangent's owned prescribed rows alone, one small MatMult per step (collective;
        # none for central difference undamped)
        self._ka = None
        if self._shift:
            own = self.motion.own if self.motion is not None else np.zeros(0, np.int64)
            self._ka = rows_of(self.force.tangent(), self.first + own, comm)
        self._viscous = self.force.viscous
        self.thermal = None
        heat = model.heat
        if heat is not None and heat.spec.expansion > 0 and self.force.blocks:
            self.thermal = ThermalForce(self, self.force.blocks, model.points, heat.n_model,
                                        heat.spec)
            self.built.append("thermal forces alpha G dT of the elements (G: "
                              f"{self.held_dofs.size}x{heat.n_model})")
        self.step_once = self.integrator.bind(self)   # step_once(t1): one step to time t1
        self.steps = 0
        self.wall = 0.0
        # the energy audit: what Rayleigh damping and contact dashpots dissipate,
        # h v.C v per step at the velocity the residual uses (energy/dissipated)
        self.audit = EnergyAudit(not self.force.linear or bool(self.damping), self.dt, self.n_own)

    # ------------------------------------------------------------------ set-up
    def build_force(self, model, layout):
        """The partition's force object; may add lines to ``self.built``."""
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
                      diagonal=diagonal, mat_type=default_type(self.dof, solved))

    def whole_held(self):
        """Held nodes of the whole partition (all its pieces; those near this
        piece where the rank has its slice of the plan)."""
        return self.dist.held()

    def describe(self, stepping: bool = True) -> str:
        """The log's line of this piece; ``stepping`` False: its nodes alone (a
        static analysis takes no step)."""
        lay = self.layout
        ext = " + ".join(str(l.size) for l in lay.layers) or "0"
        piece = f" piece {lay.piece + 1}/{lay.pieces}" if lay.pieces > 1 else ""
        how = (f"{self.method}, {self.integrator.describe()}; step {self.dt:.3e} s x "
               f"{self.n_sub} per system step; " if stepping else f"{self.method}; ")
        return (f"{self.name}{piece}: {how}nodes: {lay.n_owned} owned (boundary "
                f"{_ids(lay.boundary)}, interior {lay.interior.size}), external {ext} in "
                f"{len(lay.layers)} layer(s) {_ids(lay.external)}")

    # ------------------------------------------------------- for the schemes
    @contextmanager
    def loads_off(self):
        """Inside, the residual applies no load (a response to other causes alone)."""
        with self.loads.off():
            yield

    def clear_external_mass_damping(self):
        """No alpha M v on the external rows (their inertia is another side's)."""
        if self.damping:
            self.damping.clear_rows(self.n_own)

    # ---------------------------------------------------------------- physics
    def residual(self, t, u, v):
        """r = f(t) - K u - C v, C = alpha M + beta K (undamped partitions ignore v).
        A nonlinear force is evaluated at u (at time t, when bonds break), its
        stiffness-proportional damping with the tangent at rest.  Prescribed
        rows of u and v take their motion at t first."""
        motion = self.motion
        if motion is not None:
            motion.impose(u, v, t)
        if not self.force.linear:
            self.force.now = t
            self.internal_force(u, self.r)
            if v is not None and self._viscous is not None:            # contact dashpots
                self.audit.add(self._viscous(v, self.r))
            if self.damping and v is not None:
                self.damping.nonlinear(self.force.tangent(), v, self.r, self.audit,
                                       self.force.release_broken
                                       if self.force.bonded and self.force.break_strain
                                       is not None else None)
        elif self.damping and v is not None:
            self.damping.linear(self.internal_force, u, v, self.r, self.audit)
        else:
            self.internal_force(u, self.r)
        self.loads.apply(self.R, t)
        if self.thermal is not None:
            self.vectors.R += self.thermal.force
        if motion is not None:
            motion.capture()

    def set_temperature(self, T_node, count=True):
        """Model-node temperatures (``heat``): thermal forces, bond rest lengths and
        strengths follow; the rest lengths' work (the strain energy they change)
        goes into the external work unless not ``count``."""
        if self.thermal is not None:
            self.thermal.set_temperature(T_node)
        if self.force.bonded:                 # bond rest lengths and strengths follow T
            self.work += self.force.set_temperature(T_node, count)

    def track_thermal_work(self, count=True):
        """After a system step: the thermal forces' work over it (external work)."""
        if self.thermal is not None:
            self.work += self.thermal.track(count)

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
        self.loads.remember(self.U)
        if self.motion is not None:
            self.motion.remember(self.U, self.V)
        self.stepping = True

    def load_memory(self) -> dict:
        """{load key: last load value} of the owned load groups, and the last
        residual of the owned prescribed DOFs (checkpoint state)."""
        memory = self.loads.memory()
        if self.motion is not None:
            memory.update(self.motion.memory())
        return memory

    def restore_load_memory(self, values: dict):
        self.loads.restore(values, self.U)
        if self.motion is not None:
            self.motion.restore(values, self.U, self.V)

    def track_work(self):
        """External work += the owned loads' and prescribed motions' since the last
        call (collective where a piece of the partition has prescribed motion)."""
        self.loads.track(self.U)
        ka = None
        if self._shift:
            rows, out = self._ka
            rows.mult(self.a, out)                               # -K a' on the prescribed rows
            ka = out.getArray(readonly=True)
        if self.motion is not None:
            self.loads.work += self.motion.track(self.U, self.V, self._shift, ka)

    def after_step(self):
        """Bookkeeping after every completed step: step count and external work."""
        self.steps += 1
        self.track_work()

    def advance(self, t0: float):
        """One system step: ``n_sub`` steps of size ``dt`` from time ``t0``."""
        step, h = self.step_once, self.dt
        if self.loads.owned or self._moving:
            track = self.track_work if self._moving else partial(self.loads.track, self.U)
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
        return self.vectors.work[name]

    def local_index(self, node: int, component: int) -> int:
        loc = int(self.layout.local(np.array([node]))[0])
        return int(self.starts[loc]) + component

    def destroy(self):
        self.vectors.destroy()
        self.masses.destroy()
        self.force.destroy()
        if self.thermal is not None:
            self.thermal.destroy()
        for vec in self._views:
            vec.destroy()
        for obj in self._ka or ():
            obj.destroy()
        if self.damping:
            self.damping.destroy()


def _ids(nodes, limit=6) -> str:
    nodes = list(map(int, nodes))
    if len(nodes) <= limit:
        return str(nodes)
    return f"[{', '.join(map(str, nodes[:limit]))}, ... {len(nodes)} nodes]"
