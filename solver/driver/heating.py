"""The two clocks of a heated run (``heat``): a documented time scaling.

Heating takes seconds, elastic waves need sub-microsecond steps.  One thermal
step of ``heat.step`` seconds of heating spans ``heat.every`` mechanical system
steps, so on the mechanical clock the heating runs S = step / (every x system
step) times faster than in reality; before every system step the model-node
temperatures at heating time S (t + Dt/2 - heat.start) (linear between thermal
steps) set the thermal forces, the bond rest lengths and their strengths.
The mechanics then follows the temperature quasi-statically as long as a
thermal step spans many periods of the structure's slowest mode that the
heating excites; docs/heat.md shows how the onset of cracking moves with
``every``.  The heat does not feel the mechanics, so every rank steps the same
conduction model (:mod:`solver.model.heat`) and a restart re-steps it.
"""
from __future__ import annotations

import numpy as np

from solver.driver.observers import Observer


class Heating(Observer):
    def __init__(self, conduction, parts, scene):
        self.conduction = conduction.start()
        self.parts = parts
        self.spec = spec = scene.heat
        self.Dt = scene.system_dt
        self.scale = spec.step / (spec.every * self.Dt)
        self.T_node = conduction.node_temperature(conduction.T)
        self._last = None
        self.series = {"t": [], "heating_time": [], "max_temperature": []}

    def heating_time(self, t_mech: float) -> float:
        return max(0.0, t_mech - self.spec.start) * self.scale

    def describe(self) -> str:
        c, spec = self.conduction, self.spec
        laser = spec.laser
        spot = (f"; laser spot at {list(laser.centre)} radius {laser.radius:g} m absorbing "
                f"{laser.absorptivity * laser.power_density * np.pi * laser.radius ** 2:.4g} W"
                if laser else "; no heat source (no heat.laser): the temperature stays at heat.initial")
        return (f"heat: conduction on {c.capacity.size} mesh nodes, thermal step {spec.step:g} s "
                f"(explicit limit {c.critical:.4g} s) every {spec.every} system steps: heating "
                f"runs {self.scale:.4g} x faster on the mechanical clock{spot}")

    def before_step(self, step: int) -> None:
        """Observer hook: the temperatures of the system step to come."""
        self.update(step)

    def update(self, s: int):
        """The temperatures for system step s -> s + 1 (at its midpoint).  The
        first call (s > 0 after a restart) first sets step s - 1's temperatures,
        so the rest lengths' work of this update counts as in an unbroken run."""
        th = self.heating_time((s + 0.5) * self.Dt)
        first = self._last is None
        if first:
            for part in self.parts:                     # the thermal forces' work from here
                part.track_thermal_work(count=False)
            if s > 0:
                self._set(self.heating_time((s - 0.5) * self.Dt), count=False)
        if th == self._last:
            return
        steps = self.conduction.steps
        self._set(th, count=not first or s > 0)
        if self.conduction.steps != steps or (first and s == 0):
            self.series["t"].append(s * self.Dt)
            self.series["heating_time"].append(th)
            self.series["max_temperature"].append(float(self.T_node.max()))

    def _set(self, th: float, count: bool):
        c = self.conduction
        self.T_node = c.node_temperature(c.at(th))
        for part in self.parts:
            part.set_temperature(self.T_node, count=count)
        self._last = th

    def stepped(self, step: int) -> None:
        """Observer hook, after every system step: the thermal forces' work over it."""
        for part in self.parts:
            part.track_thermal_work()

    def restore(self, series: dict):
        """The heating series of a checkpoint (samples before its system step)."""
        self.series = {k: list(np.asarray(series[k]).tolist()) for k in self.series if k in series}

    def arrays(self) -> dict:
        return {k: np.asarray(v) for k, v in self.series.items()}

    def destroy(self):
        self.conduction.destroy()
