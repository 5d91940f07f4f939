"""Load time functions: sine, half-sine pulse, rectangular pulse, tabulated
(piecewise linear).

Each function has ``at(t)`` for one time (plain floats: it runs every step)
and ``values(t)`` for an array of times (plots, references).  The exact
responses of a unit oscillator to these functions live in
:mod:`solver.driver.reference`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


class LoadFunction:
    """g(t) [N]."""

    def at(self, t: float) -> float:
        raise NotImplementedError

    def values(self, t: np.ndarray) -> np.ndarray:
        raise NotImplementedError


@dataclass(frozen=True)
class Sine(LoadFunction):
    """g(t) = amplitude * sin(omega t)."""

    amplitude: float
    omega: float

    def at(self, t):
        return self.amplitude * math.sin(self.omega * t)

    def values(self, t):
        return self.amplitude * np.sin(self.omega * np.asarray(t, dtype=float))


@dataclass(frozen=True)
class HalfSine(LoadFunction):
    """g(t) = amplitude * sin(pi (t - start) / duration) on [start, start + duration]."""

    amplitude: float
    duration: float
    start: float = 0.0

    def at(self, t):
        s = t - self.start
        if s < 0.0 or s > self.duration:
            return 0.0
        return self.amplitude * math.sin(math.pi * s / self.duration)

    def values(self, t):
        s = np.asarray(t, dtype=float) - self.start
        on = (s >= 0) & (s <= self.duration)
        return np.where(on, self.amplitude * np.sin(math.pi * s / self.duration), 0.0)


@dataclass(frozen=True)
class Rectangular(LoadFunction):
    """g(t) = amplitude on [start, start + duration), 0 elsewhere: a sudden load
    and unload (Zhang et al.'s (2009) bar)."""

    amplitude: float
    duration: float
    start: float = 0.0

    def at(self, t):
        s = t - self.start
        return self.amplitude if 0.0 <= s < self.duration else 0.0

    def values(self, t):
        s = np.asarray(t, dtype=float) - self.start
        return np.where((s >= 0) & (s < self.duration), self.amplitude, 0.0)


@dataclass(frozen=True)
class Tabulated(LoadFunction):
    """Piecewise linear through (times, forces); the end values are held outside."""

    times: tuple[float, ...]
    forces: tuple[float, ...]

    def at(self, t):
        return float(np.interp(t, self.times, self.forces))

    def values(self, t):
        return np.interp(np.asarray(t, dtype=float), self.times, self.forces)


def load_function(spec) -> LoadFunction:
    """The time function of a :class:`solver.scene.Load`."""
    if spec.kind == "sine":
        return Sine(spec.amplitude, spec.omega)
    if spec.kind == "half_sine":
        return HalfSine(spec.amplitude, spec.duration, spec.start)
    if spec.kind == "rectangular":
        return Rectangular(spec.amplitude, spec.duration, spec.start)
    return Tabulated(tuple(r[0] for r in spec.table), tuple(r[1] for r in spec.table))


@dataclass(frozen=True)
class PointLoad:
    """A time function times ``scale`` applied to one DOF."""

    dof: int
    function: LoadFunction
    scale: float = 1.0
