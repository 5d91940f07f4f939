"""Coupling schemes: what one system step does.

``ConcurrentOverlap`` (``coupling.scheme: overlap``, seed 000): every
partition advances ``largest ratio / ratio`` steps from the same system-step
state, then one exchange refreshes all external copies.  On as many ranks as
partitions the advances run concurrently and meet at the exchange; on one rank
they run one after the other with the same result.

``Staggered`` (``coupling.scheme: staggered``, seed 002): one explicit and one
implicit partition.  The implicit side predicts from t_n; the explicit side
sub-cycles to t_n+1 over its external layers; its boundary (u, v, a) at t_n+1
is sent to the implicit side, which solves
K_eff[BI,BI] a_BI = f_BI - (K u~ + C v~)_BI - K_eff[BI,E] a_E with those
accelerations prescribed; the implicit results are then copied to the
explicit side's externals.  The two sides alternate, so on two ranks they do
not overlap in time.
"""
from __future__ import annotations

from time import perf_counter as _clock

import numpy as np

from solver.coupling.exchange import Exchange
from solver.petscutil import Stage, init
from solver.errors import describe
from solver.partitions.partitioning import build_partitions


class _Clocks:
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


class ConcurrentOverlap:
    name = "overlap"

    @staticmethod
    def treatments(scene) -> list[str]:
        return [scene.coupling.external for _ in scene.partitions]

    @classmethod
    def build(cls, scene, model, comm, say):
        """The partitions stage (:mod:`solver.partitions.partitioning`), then the scheme."""
        built = build_partitions(scene, model, comm, cls.treatments(scene), say)
        scheme = cls(comm, built.dists, built.assignment, built.parts, built.model.dofmap, scene)
        scheme.layouts, scheme.freqs, scheme.model = built.layouts, built.freqs, built.model
        return scheme

    def __init__(self, comm, dists, ranks, parts, dofmap, scene):
        self.parts = parts
        need = any(d.layout.layers for d in dists)
        self.exchange = Exchange(comm, dists, ranks, parts, dofmap) if need else None
        self.exchanges = [self.exchange] if need else []
        self.clocks = _Clocks(parts, [p.name for p in scene.partitions], comm)

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

    def memory(self) -> dict:
        """What a checkpoint keeps of the scheme beyond its partitions' states
        (name -> array, this rank's part): none."""
        return {}

    def restore_memory(self, memory: dict):
        """Put :meth:`memory`'s arrays (merged over ranks) back after synchronise()."""

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

    @staticmethod
    def treatments(scene) -> list[str]:
        return ["prescribed" if p.integrator == "implicit" else scene.coupling.external
                for p in scene.partitions]

    @staticmethod
    def _solved_last(scene) -> int:
        """The partition that solves after the other side's sub-steps."""
        return next(k for k, p in enumerate(scene.partitions) if p.integrator == "implicit")

    def __init__(self, comm, dists, ranks, parts, dofmap, scene):
        self.parts = parts
        i = self._solved_last(scene)
        local = {p.layout.index: p for p in parts}
        self.implicit = local.get(i)
        self.explicit = local.get(1 - i)
        self.to_implicit = Exchange(comm, dists, ranks, parts, dofmap, receivers={i})
        self.to_explicit = Exchange(comm, dists, ranks, parts, dofmap, receivers={1 - i})
        self.exchanges = [self.to_implicit, self.to_explicit]
        self.exchange = None
        self.clocks = _Clocks(parts, [p.name for p in scene.partitions], comm)

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


class TransitionZone(Staggered):
    """``coupling.scheme: transition`` (seed 003, Fig. 2): the explicit FE
    partition steps fdt = N dt, the dem partition N steps of dt per FE step.
    (The Staggered machinery names the FE side ``implicit``: it solves last.)

    Per system step: the FE partition predicts u_n+1 = u_n + fdt v_n + fdt^2/2 a_n
    (central difference, Newmark beta 0: its displacement is its predictor);
    the dem partition sub-cycles with the band nodes (its external nodes,
    which carry the band particles) moving as ``coupling.band_motion`` says;
    the particles' state at t_n+1 goes to the FE partition, which evaluates
    the carried bonds (eq. 3) with it and finishes its step; the band nodes'
    new state goes back.  With ``predictor`` (default) the band moves on the
    FE's own path, ``linear`` straight from u_n to u_n+1, both ending on the
    FE's u_n+1; ``velocity`` (u + s v, eq. 4 read literally) and ``hold`` jump
    there.  At N = 1 this is one central-difference step of the whole model
    (docs/transition.md, which also gives the stable steps)."""

    name = "transition"

    @staticmethod
    def treatments(scene) -> list[str]:
        return ["prescribed" if p.method == "fem" else "taylor" for p in scene.partitions]

    @staticmethod
    def _solved_last(scene) -> int:
        return next(k for k, p in enumerate(scene.partitions) if p.method == "fem")

    def __init__(self, comm, dists, ranks, parts, dofmap, scene):
        super().__init__(comm, dists, ranks, parts, dofmap, scene)
        motion = scene.coupling.band_motion
        ext, fe = self.explicit, self.implicit
        self._band = None
        self._linear = None
        if ext is not None and motion == "linear":
            n = ext.n_own
            self._linear = (ext.V[n:], ext.A[n:], 0.5 * scene.system_dt)
        elif ext is not None and motion != "predictor":
            n = ext.n_own
            self._band = ext.A[n:] if motion == "velocity" else ext.state[1:, n:]
        if fe is not None:
            # the particles' exchanged state at t_n+1 is what the FE forces use
            # (explicit Newmark evaluates its residual at the predicted u~, v~)
            n = fe.n_own
            self._particles = ((fe.U[n:], fe.work_array("ut")[n:]),
                               (fe.V[n:], fe.work_array("vt")[n:]))

    def describe(self) -> str:
        return ("transition-zone scheme (Zhang et al. 2009): dem sub-steps over the band's motion, then the "
                "explicit FE step with the particles' forces on its band nodes")

    def _finish(self, t1):
        for exchanged, predicted in self._particles:
            np.copyto(predicted, exchanged)
        super()._finish(t1)

    def _received(self):
        if self._band is not None:
            self._band[...] = 0.0          # velocity: a = 0; hold: v = a = 0 until the next sync
        elif self._linear is not None:     # linear: v = (u_n+1 - u_n) / fdt = v + fdt/2 a, a = 0
            v, a, half = self._linear
            v += half * a
            a[...] = 0.0

    def synchronise(self):
        super().synchronise()
        self._received()
