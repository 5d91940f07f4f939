"""What the step loop (:func:`solver.driver.runner.step_loop`) calls on the
things that watch a run: probes, the energy guard, field frames, the heating,
checkpoints and the progress line.

Every observer is an :class:`Observer`; a hook it does not need is the base's,
which does nothing.  The loop calls, in list order:

* ``start(first, last)`` once: it steps from system step ``first`` to ``last``;
* ``before_step(step)`` and ``stepped(step + 1)`` around every system step, inside
  the step's failure guard (an exception there stops every rank together);
* ``needs_poll(step)``: True where every rank must agree the run goes on before
  ``after_step`` (a checkpoint is written only by a run that is still going);
* ``after_step(step, t)`` after system step ``step`` at time ``t``; a message
  returned ends the run with that failure (later observers are not called);
* ``finish(step, t)`` once, after the last system step done.
"""
from __future__ import annotations

import time


class Observer:
    """The step loop's protocol; this base does nothing."""

    def start(self, first: int, last: int) -> None:
        pass

    def before_step(self, step: int) -> None:
        pass

    def stepped(self, step: int) -> None:
        pass

    def needs_poll(self, step: int) -> bool:
        return False

    def after_step(self, step: int, t: float) -> str | None:
        return None

    def finish(self, step: int, t: float) -> None:
        pass


def hooks(observers, name: str) -> list:
    """The bound ``name`` hooks of the observers that override the base's (in list
    order): the step loop calls only those, not the do-nothing ones, every step."""
    base = getattr(Observer, name)
    return [getattr(ob, name) for ob in observers if getattr(type(ob), name) is not base]


class Progress(Observer):
    """A progress line every ``seconds`` of stepping (checked every 256 system
    steps): time, elapsed and remaining wall time, the guard's latest energies."""

    def __init__(self, say, seconds: float, guard, dt: float):
        self.say, self.seconds, self.guard, self.dt = say, seconds, guard, dt

    def start(self, first: int, last: int) -> None:
        self.first, self.last = first, last
        self.t_loop = self.shown = time.perf_counter()

    def after_step(self, step: int, t: float) -> None:
        if (step & 255) == 0 and time.perf_counter() - self.shown >= self.seconds:
            self.shown = time.perf_counter()
            frac, el = (step - self.first) / (self.last - self.first), self.shown - self.t_loop
            self.say(f"[solver] t = {step * self.dt:.6g}/{self.last * self.dt:.6g} s "
                     f"({100 * step / self.last:.0f}%), {el:.1f} s elapsed, about "
                     f"{el * (1 - frac) / frac:.1f} s to go; {self.guard.latest()}")
