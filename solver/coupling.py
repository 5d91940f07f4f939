"""Coupling schemes: what one system step does.

``ConcurrentOverlap`` (``coupling.scheme: overlap``, seed 000): every
partition advances ``largest ratio / ratio`` steps from the same system-step
state, then one exchange refreshes all external copies.  On as many ranks as
partitions the advances run concurrently and meet at the exchange; on one rank
they run one after the other with the same result, since partitions only see
each other through the exchange.  The staggered and GC schemes plug in here.
"""
from __future__ import annotations

import time

from .petscutil import Stage


class ConcurrentOverlap:
    name = "overlap"

    def __init__(self, parts, exchange):
        self.parts = parts
        self.exchange = exchange
        self._stages = [Stage(p.name) for p in parts]
        self._stage_x = Stage("exchange")
        self.exchange_wall = 0.0

    def describe(self) -> str:
        return "concurrent overlap scheme (seed 000): advance all partitions, then exchange"

    def initialise(self, model):
        """Initial state and accelerations; externals taken from their owners."""
        for part in self.parts:
            part.initialise(model)
        if self.exchange:
            self.exchange()

    def step(self, t0: float):
        """One system step from time ``t0``."""
        clock = time.perf_counter
        for part, stage in zip(self.parts, self._stages):
            stage.push()
            c0 = clock()
            part.advance(t0)
            part.wall += clock() - c0
            stage.pop()
        if self.exchange:
            self._stage_x.push()
            c0 = clock()
            self.exchange()
            self.exchange_wall += clock() - c0
            self._stage_x.pop()


SCHEMES = {"overlap": ConcurrentOverlap}
