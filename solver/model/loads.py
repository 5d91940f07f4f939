"""Load time functions: sine, half-sine pulse, rectangular pulse, tabulated
(piecewise linear).

Each function has ``at(t)`` for one time (plain floats: it runs every step)
and ``values(t)`` for an array of times (plots, references); ``rate(t)``
(dg/dt) and ``integral(t)`` (the integral of g from 0 to t) serve prescribed
motions (:mod:`solver.model.prescribed`): a displacement's velocity, a
velocity's displacement.  The exact
responses of a unit oscillator to these functions live in
:mod:`solver.driver.reference`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np


class LoadFunction:
    """g(t) [N]."""

    def at(self, t: float) -> float:
        raise NotImplementedError

    def values(self, t: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def rate(self, t: float) -> float:
        """dg/dt (one-sided where g has a kink: the value on the segment t starts)."""
        raise NotImplementedError

    def integral(self, t: float) -> float:
        """The integral of g over [0, t]."""
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

    def rate(self, t):
        return self.amplitude * self.omega * math.cos(self.omega * t)

    def integral(self, t):
        return self.amplitude * (1.0 - math.cos(self.omega * t)) / self.omega


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

    def rate(self, t):
        s = t - self.start
        if s < 0.0 or s >= self.duration:
            return 0.0
        k = math.pi / self.duration
        return self.amplitude * k * math.cos(k * s)

    def integral(self, t):
        s = min(max(t - self.start, 0.0), self.duration)
        return self.amplitude * self.duration / math.pi * (1.0 - math.cos(math.pi * s / self.duration))


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

    def rate(self, t):
        return 0.0              # (its jumps have no rate: a scene cannot prescribe it as a displacement)

    def integral(self, t):
        return self.amplitude * min(max(t - self.start, 0.0), self.duration)


@dataclass(frozen=True)
class Tabulated(LoadFunction):
    """Piecewise linear through (times, forces); the end values are held outside."""

    times: tuple[float, ...]
    forces: tuple[float, ...]

    def at(self, t):
        return float(np.interp(t, self.times, self.forces))

    def values(self, t):
        return np.interp(np.asarray(t, dtype=float), self.times, self.forces)

    def rate(self, t):
        T, F = self.times, self.forces
        if t < T[0] or t >= T[-1]:
            return 0.0
        k = int(np.searchsorted(T, t, side="right")) - 1
        return (F[k + 1] - F[k]) / (T[k + 1] - T[k])

    def integral(self, t):
        return self._antiderivative(t) - self._antiderivative(0.0)

    @cached_property
    def _areas(self) -> np.ndarray:
        """The integral of g from T_0 to each T_k."""
        T, F = np.asarray(self.times), np.asarray(self.forces)
        return np.concatenate([[0.0], np.cumsum(0.5 * (F[1:] + F[:-1]) * np.diff(T))])

    def _antiderivative(self, t):
        """G(t) with G(T_0) = 0, g held constant outside the table."""
        T, F = self.times, self.forces
        if t <= T[0]:
            return F[0] * (t - T[0])
        areas = self._areas
        if t >= T[-1]:
            return float(areas[-1] + F[-1] * (t - T[-1]))
        k = int(np.searchsorted(T, t, side="right")) - 1
        s = t - T[k]
        slope = (F[k + 1] - F[k]) / (T[k + 1] - T[k])
        return float(areas[k] + F[k] * s + 0.5 * slope * s * s)


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
