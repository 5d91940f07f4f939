"""The energy audit of a partition: what Rayleigh damping and contact dashpots
dissipate, h v.C v per step at the velocity the residual uses, summed over the
owned DOFs (``energy/dissipated``).

    track       bool: the partition dissipates at all (damped, or a nonlinear force)
    stepping    bool: count now (set once initialised; a scheme clears it around
                a pass whose dissipation is not the run's)
    dissipated  float: the sum so far (a checkpoint keeps it)
"""
from __future__ import annotations

import numpy as np


class EnergyAudit:
    def __init__(self, track: bool, dt: float, n_own: int):
        self.track, self.dt, self.n_own = track, dt, n_own
        self.dissipated = 0.0
        self.stepping = False

    def add(self, power: float):
        """dissipated += h power (a force's own dissipated power, e.g. dashpots)."""
        if self.track and self.stepping:
            self.dissipated += self.dt * power

    def dissipate(self, v, w, scale: float):
        """dissipated += h scale v . w over the owned DOFs (Vecs ``v``, ``w``)."""
        if self.track and self.stepping:
            n = self.n_own
            self.dissipated += self.dt * scale * float(
                np.dot(v.getArray(readonly=True)[:n], w.getArray(readonly=True)[:n]))
