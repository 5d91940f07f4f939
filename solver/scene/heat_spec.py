"""The ``heat`` section: conduction, a laser spot, thermal expansion and the
temperature-weakened bonds (Zhang et al. 2009, §3's laser-heated plate).

How the slow heating meets the fast waves is a documented time scaling
(docs/heat.md): one thermal step ``step`` [s of heating] spans ``every``
mechanical system steps, so heating runs step / (every x system step) times
faster on the mechanical clock than in reality.
"""
from __future__ import annotations

from dataclasses import dataclass

from solver.scene.schema import fail, key


@dataclass(frozen=True)
class LaserSpec:
    centre: tuple[float, ...] = key("spot centre [m] (x, y): it must lie on the body")
    radius: float = key("spot radius R [m]: intensity I0 exp(-2 r^2 / R^2) (the 1/e^2 radius)",
                        positive=True)
    power_density: float = key("mean power density over the spot [W/m^2]: P / (pi R^2); the "
                               "peak I0 is twice it", positive=True)
    absorptivity: float = key("fraction of the light absorbed by the surface (0..1]",
                              positive=True)
    start: float = key("heating time [s] when the laser switches on", 0.0, nonnegative=True)

    def validate(self, path):
        if self.absorptivity > 1:
            fail(f"{path}.absorptivity", f"{self.absorptivity:g}: a fraction of the light, at "
                 "most 1")
        if len(self.centre) != 2:
            fail(f"{path}.centre", f"{list(self.centre)}: a point (x, y) on the plate")


@dataclass(frozen=True)
class HeatSpec:
    conductivity: float = key("thermal conductivity k [W/(m K)]", positive=True)
    specific_heat: float = key("specific heat c [J/(kg K)] (the capacity is rho c per volume)",
                               positive=True)
    step: float = key("thermal step [s of heating] (explicit conduction; refused beyond "
                      "its stable limit, which the log prints)", positive=True)
    every: int = key("mechanical system steps per thermal step: the time scaling of "
                     "docs/heat.md (the temperature is interpolated linearly in between)",
                     positive=True)
    expansion: float = key("linear thermal expansion coefficient alpha [1/K]: FE thermal "
                           "strain alpha dT, bond rest lengths L0 (1 + alpha dT)", 0.0,
                           nonnegative=True)
    initial: float = key("initial (and reference, stress-free) temperature T0 [K]", 293.0,
                         positive=True)
    melting: float | None = key(
        "melting point Tm [K]: a bond's critical strain falls linearly from "
        "model.lattice.break_strain at T0 to zero at Tm; default: strength independent of "
        "temperature", None, positive=True)
    start: float = key("mechanical time [s] at which heating begins (e.g. once a pre-load "
                       "has settled)", 0.0, nonnegative=True)
    laser: LaserSpec | None = key("Gaussian laser spot on the surface of a plane_stress "
                                  "plate (absorbed through its thickness)", None)

    def validate(self, path):
        if self.melting is not None and self.melting <= self.initial:
            fail(f"{path}.melting", f"{self.melting:g} K is not above heat.initial "
                 f"{self.initial:g} K: every bond would break at rest")
