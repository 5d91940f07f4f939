"""Checkpoints while a run steps: the output file with the run state every
``output.checkpoint.every`` system steps (status running), and what the final
file keeps (:meth:`Checkpoint.final`).  The state's format is
:mod:`solver.driver.state`'s."""
from __future__ import annotations

import time

from solver.driver import output, state
from solver.driver.observers import Observer


class Checkpoint(Observer):
    """Writes the output file with the run state (:mod:`solver.driver.state`) every
    ``every`` system steps, status running, atomically: an observer of the step
    loop (:mod:`solver.driver.observers`)."""

    def __init__(self, every, scene, parts, guard, comm, report):
        self.every, self.scene, self.parts, self.guard = every, scene, parts, guard
        self.comm, self.report = comm, report
        self.meta = {"fingerprint": state.fingerprint(scene), "scene": scene.name}

    def start(self, first: int, last: int) -> None:
        self.last_step, self.t_loop = last, time.perf_counter()

    def needs_poll(self, step: int) -> bool:
        """Every rank agrees the run goes on before a checkpoint is written."""
        return step % self.every == 0

    def after_step(self, step: int, t: float) -> None:
        if step % self.every == 0 and step < self.last_step:
            self.write(step, time.perf_counter() - self.t_loop)

    def write(self, k: int, wall: float):
        """The output file with the state after system step ``k`` (collective)."""
        data = state.collect(k, self.parts, self.guard, self.comm, self.report.asm.scheme)
        result = self.report.result(k, "running", "", wall)
        if self.comm.rank == 0:
            self.last = (data, self.meta)
            output.write(self.scene.output_file, result, checkpoint=state.group_writer(self.last))

    def final(self, done: int, failure):
        """What the final file keeps: the state at ``done`` (collective), or after
        a failure the last checkpoint written (rank 0; None elsewhere)."""
        if failure:
            return getattr(self, "last", None)
        data = state.collect(done, self.parts, self.guard, self.comm, self.report.asm.scheme)
        return (data, self.meta) if data is not None else None
