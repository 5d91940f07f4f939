"""Coupling schemes: what one system step does.

``ConcurrentOverlap`` (``coupling.scheme: overlap``, Li et al. 2023): every
partition advances ``largest ratio / ratio`` steps from the same system-step
state, then one exchange refreshes all external copies.  On as many ranks as
partitions the advances run concurrently and meet at the exchange; on one rank
they run one after the other with the same result.

``Staggered`` (``coupling.scheme: staggered``, Ma et al. 2018): one explicit and one
implicit partition.  The implicit side predicts from t_n; the explicit side
sub-cycles to t_n+1 over its external layers; its boundary (u, v, a) at t_n+1
is sent to the implicit side, which solves
K_eff[BI,BI] a_BI = f_BI - (K u~ + C v~)_BI - K_eff[BI,E] a_E with those
accelerations prescribed; the implicit results are then copied to the
explicit side's externals.  The two sides alternate, so on two ranks they do
not overlap in time.  ``TransitionZone`` (:mod:`solver.coupling.transition_zone`)
builds on ``Staggered``.
"""
from __future__ import annotations

from time import perf_counter as _clock

from solver.coupling.exchange import Exchange
from solver.coupling.scheme import Scheme, two_sides
from solver.partitions import integrators
from solver.petscutil import Stage, init
from solver.errors import describe
from solver.partitions.partitioning import build_partitions


class Clocks:
    """Wall time of partitions and exchanges, and PETSc logging stages (one per
    partition, one for the exchange) when PETSc logging is on (-log_view).

    After :meth:`measure_wait` (the run option ``measure_wait``, on the command
    line ``-exchange_measure_wait``) every exchange is preceded by a barrier on
    ``comm``: the time in the barrier is the wait for the slowest rank
    (``wait_wall``), the rest the exchange itself (``exchange_wall``).  Without
    it, ``exchange_wall`` includes the wait."""

    def __init__(self, parts, names=None, comm=None):
        # every rank registers every partition's stage in the same order (PETSc
        # matches stages across ranks by registration order), then the exchange
        self._stages = {n: Stage(n) for n in (names or [p.name for p in parts])}
        self._stage_x = Stage("exchange")
        self.exchange_wall = 0.0
        self.wait_wall = None
        self.failures = []          # "partition 'x': message" of partitions that failed
        self.comm = comm
        P = init()
        self.logging = P.Log.isActive()
        if not self.logging:
            self.part, self.exchange = self._part, self._exchange

    def measure_wait(self):
        """From now on a barrier on ``comm`` (several ranks) before every exchange:
        its time is the wait for the slowest rank (``wait_wall``)."""
        if self.comm is not None and self.comm.size > 1:
            self.wait_wall, self._barrier = 0.0, self.comm.Barrier
            self._exchange = self._exchange_after_barrier
            if not self.logging:
                self.exchange = self._exchange

    def part(self, part, fn, *args):
        stage = self._stages[part.name]
        stage.push()
        self._part(part, fn, *args)
        stage.pop()

    def exchange(self, exchange):
        self._stage_x.push()
        self._exchange(exchange)
        self._stage_x.pop()

    def _part(self, part, fn, *args):
        if part.failed:
            return
        c0 = _clock()
        try:
            fn(*args)
        except Exception as e:                  # noqa: BLE001 -- any failure stops the run together
            self.failed(part, e)
        part.wall += _clock() - c0

    def failed(self, part, error):
        """Mark ``part`` failed: it stops stepping, the scheme goes on exchanging
        until the run stops on every rank (:mod:`solver.driver.stop`)."""
        part.failed = True
        message = describe(error)
        if not message.startswith(f"partition '{part.name}'"):
            message = f"partition '{part.name}': {message}"
        self.failures.append(message)

    def _exchange(self, exchange):
        c0 = _clock()
        exchange()
        self.exchange_wall += _clock() - c0

    def _exchange_after_barrier(self, exchange):
        c0 = _clock()
        self._barrier()
        c1 = _clock()
        exchange()
        self.wait_wall += c1 - c0
        self.exchange_wall += _clock() - c1


class ConcurrentOverlap(Scheme):
    name = "overlap"
    levels = True
    summary = ("concurrent scheme of Li et al. (2023), partitions advance from the same "
               "system-step state and exchange once per system step")
    about = ("Li et al.'s (2023) concurrent scheme: the partitions advance side by side from the "
             "same system-step state, overlap by one layer of external nodes and exchange "
             "displacement, velocity and acceleration once per system step")
    supports = ("network and continuum models; any number of partitions, each fem+explicit, "
                "fem+implicit or dem+verlet; any number of ranks; external: taylor, layers, "
                "literal")
    limit = ("each explicit partition's own limit (omega_max h < 2 on its step); an implicit "
             "partition has none alone, but coupled beyond about 1.4 x the explicit critical "
             "step it can go unstable (a warning is printed before stepping; the energy "
             "guard stops a blow-up)")
    uses_external = True
    max_ranks = None
    hands_over = True          # the partitions stage may let go of rank 0's whole model

    @staticmethod
    def treatments(scene) -> list[str]:
        return [scene.coupling.external for _ in scene.partitions]

    @classmethod
    def build(cls, scene, model, comm, say, assignment=None):
        """The partitions stage (:mod:`solver.partitions.partitioning`), then the scheme;
        ``assignment``: the ranks to build on instead of those by estimated cost."""
        return cls(scene, build_partitions(scene, model, comm, cls.treatments(scene), say,
                                           assignment), comm)

    def __init__(self, scene, built, comm):
        """``built``: the partitions stage's :class:`~solver.partitions.partitioning.Partitions`."""
        self.parts, self.owned_counts, self.freqs, self.model = (
            built.parts, built.owned_counts, built.freqs, built.model)
        self.assignment = built.assignment
        self.exchanges = self._exchanges(scene, built, comm)
        self.clocks = Clocks(self.parts, [p.name for p in scene.partitions], comm)

    def _exchanges(self, scene, built, comm) -> list:
        """One exchange refreshing every partition's externals (``exchange``;
        none without externals)."""
        need = any(d.n_layers for d in built.dists)
        self.exchange = Exchange(comm, built.dists, built.assignment, built.parts,
                                 built.model.dofmap) if need else None
        return [self.exchange] if need else []

    def describe(self) -> str:
        return "concurrent overlap scheme (Li et al. 2023): advance all partitions, then exchange"

    def initialise(self, model):
        """Initial state and accelerations; externals taken from their owners."""
        for part in self.parts:
            part.initialise(model)
        self.synchronise()

    def synchronise(self):
        """Externals from their owners, as at the end of a system step."""
        for exchange in self.exchanges:
            exchange()

    def step(self, t0: float):
        """One system step from time ``t0``."""
        clocks = self.clocks
        if clocks.logging or clocks.wait_wall is not None:
            for part in self.parts:
                clocks.part(part, part.advance, t0)
            if self.exchange:
                clocks.exchange(self.exchange)
            return
        c0 = _clock()                           # the same without logging stages, inline
        for part in self.parts:
            if not part.failed:
                try:
                    part.advance(t0)
                except Exception as e:          # noqa: BLE001
                    clocks.failed(part, e)
            c1 = _clock()
            part.wall += c1 - c0
            c0 = c1
        if self.exchange:
            self.exchange()
            clocks.exchange_wall += _clock() - c0


class Staggered(ConcurrentOverlap):
    name = "staggered"
    summary = ("Ma et al. (2018), the explicit partition sub-cycles, then the implicit partition "
               "solves with its accelerations prescribed")
    about = ("Ma et al.'s (2018) explicit-implicit scheme: the explicit partition sub-cycles over "
             "the system step, then the implicit partition solves its step with the "
             "explicit side's accelerations prescribed on the interface")
    supports = ("network and continuum models; exactly two partitions: fem+implicit with the "
                "largest ratio, and fem+explicit or dem+verlet; any number of ranks; external "
                "(of the explicit side; the implicit side's are prescribed): taylor, layers, "
                "literal")
    limit = ("the explicit partition's own limit; the implicit one has none alone, but "
             "coupled beyond about 1.4 x the explicit critical step it can go unstable (a "
             "warning is printed before stepping; the energy guard stops a blow-up)")

    @classmethod
    def validate(cls, scene):
        two_sides(scene, cls.name)
        super().validate(scene)

    @staticmethod
    def treatments(scene) -> list[str]:
        return ["prescribed" if integrators.kind(p).implicit else scene.coupling.external
                for p in scene.partitions]

    @staticmethod
    def _solved_last(scene) -> int:
        """The partition that solves after the other side's sub-steps."""
        return next(k for k, p in enumerate(scene.partitions) if integrators.kind(p).implicit)

    def _exchanges(self, scene, built, comm) -> list:
        """One exchange per direction: to the solving side, then back."""
        i = self._solved_last(scene)
        local = {p.layout.index: p for p in built.parts}
        self.implicit = local.get(i)
        self.explicit = local.get(1 - i)
        args = comm, built.dists, built.assignment, built.parts, built.model.dofmap
        self.to_implicit = Exchange(*args, receivers={i})
        self.to_explicit = Exchange(*args, receivers={1 - i})
        self.exchange = None
        return [self.to_implicit, self.to_explicit]

    def describe(self) -> str:
        return ("staggered scheme (Ma et al. 2018): explicit sub-cycle, then the implicit solve with "
                "the explicit side's accelerations prescribed")

    def _finish(self, t1):
        """The solving side's step to t1, once the other side's state is in."""
        imp = self.implicit
        imp.integrator.finish(imp, t1)
        imp.after_step()

    def _received(self):
        """After the solving side's results reached the other side (a hook)."""

    def step(self, t0: float):
        imp, exp = self.implicit, self.explicit
        if imp:
            self.clocks.part(imp, imp.integrator.predict, imp)
        if exp:
            self.clocks.part(exp, exp.advance, t0)
        self.clocks.exchange(self.to_implicit)
        if imp:
            self.clocks.part(imp, self._finish, t0 + imp.dt)
        self.clocks.exchange(self.to_explicit)
        self._received()
