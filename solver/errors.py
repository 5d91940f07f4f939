"""Error types the command line turns into one-line messages and exit codes.

Library code raises these; only :mod:`solver.tools.cli` decides how a process ends.
"""


class SolverError(Exception):
    """Base class: a problem we can explain in one line."""

    exit_code = 1


class SceneError(SolverError):
    """Bad input: a scene key, value, file or entity. Nothing has run yet."""

    exit_code = 2


class StabilityError(SceneError):
    """An explicit partition's step is at or above its critical step."""

    exit_code = 2


class LaunchError(SolverError):
    """The MPI launcher and library disagree, or the rank count does not fit."""

    exit_code = 4


class RunFailed(SolverError):
    """The run started but had to stop (non-finite state, energy growth)."""

    exit_code = 3


def describe(error: BaseException) -> str:
    """One line for any exception raised while a partition steps."""
    text = str(error).strip().splitlines()
    line = text[-1] if text else type(error).__name__
    return line if isinstance(error, RunFailed) else f"{type(error).__name__}: {line}"
