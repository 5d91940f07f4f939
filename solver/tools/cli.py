"""Command line: ``python -m solver SCENE.yaml [--set key.path=value ...] [PETSc options]``.

Also ``python -m solver keys`` (every scene key with type, default and
documentation) and ``python -m solver schemes`` (integrators and coupling
schemes with their stability limits).  Errors end the process with one line
on stderr and an exit code (docs/reference/exit-codes.md): 2 bad scene or unstable step,
3 run stopped (non-finite state, energy growth), 4 MPI launch problem.
"""
from __future__ import annotations

import difflib
import os
import re
import sys
import time
from pathlib import Path

from solver.errors import LaunchError, SceneError, SolverError
from solver.threads import one_blas_thread

USAGE = """usage: ./run.sh [-n N] SCENE.yaml [--set key.path=value ...] [--restart FILE] [--overwrite] [PETSc options]
       ./run.sh test                          the test suite
       ./run.sh sweep SCENE.yaml --ratios 1,2,5 [-n 1,2] [--treatments ...] [--dts ...] [--schemes ...]
       ./run.sh plot RESULT.h5 [MORE.h5 ...] [--probe NAME] [-o FILE.png]
       ./run.sh plan SCENE.yaml [--scaling 1.5,2,4]   predicted cost: uniform step, levels, mass scaling
       ./run.sh bench [--all]                 the benchmarks (benchmarks/bench_*.py; --all: the slow ones too)
       ./run.sh keys [--markdown]             every scene key: type, default, meaning
       ./run.sh schemes                       integrators and coupling schemes, stability limits
mts-solver and python -m solver take the same forms (scene, sweep, plot, plan, keys, schemes, --version)
on one process; test and bench need the checkout's ./run.sh.
PETSc options (e.g. -options_file configs/implicit_cg.opts, -log_view, -fem_mat_type baij) go
to PETSc; every partition's PETSc objects carry the prefix <partition name>_ ;
-exchange_measure_wait times the wait for the slower rank apart from the exchange.
--restart FILE goes on from FILE's checkpoint; --overwrite lets a fresh run replace an output
file that holds a checkpoint (refused otherwise)."""

FLAGS = ("--set", "--restart", "--overwrite", "--help")

LAUNCH_VARS = ("PMI_SIZE", "OMPI_COMM_WORLD_SIZE", "PMIX_SIZE", "MPI_LOCALNRANKS")


def split_args(argv):
    """(scene path, overrides, PETSc options, restart file, overwrite) from the
    command line.  A ``--`` word that is not one of ours is refused here, before
    anything is built (PETSc's options have one dash)."""
    scene, overrides, petsc, restart, overwrite = None, [], [], None, False
    it = iter(argv)
    for arg in it:
        if arg == "--restart" or arg.startswith("--restart="):
            restart = arg.split("=", 1)[1] if "=" in arg else next(it, None)
            if not restart:
                raise SceneError("--restart needs the output file of an earlier run")
        elif arg == "--set":
            value = next(it, None)
            if value is None:
                raise SceneError("--set needs key.path=value")
            overrides.append(value)
        elif arg.startswith("--set="):
            overrides.append(arg[len("--set="):])
        elif arg == "--overwrite":
            overwrite = True
        elif arg.startswith("--"):
            raise SceneError(f"unknown option {clip(arg)}{nearest(arg.split('=')[0], FLAGS)} "
                             "(./run.sh --help lists the forms; PETSc options have one dash)")
        elif scene is None and not arg.startswith("-") and arg.endswith((".yaml", ".yml")):
            scene = arg
        else:
            petsc.append(arg)
    return scene, overrides, petsc, restart, overwrite


def clip(text: str, limit: int = 80) -> str:
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} characters)"


def nearest(word: str, known) -> str:
    """'' or ' (did you mean X?)' for the known word closest to ``word``."""
    match = difflib.get_close_matches(word, list(known), n=1, cutoff=0.6)
    return f" (did you mean {match[0]}?)" if match else ""


def check_launch(comm):
    """Refuse a launcher/library mismatch: the launcher started N processes but
    MPI reports a world of one (every rank thinks it is alone)."""
    for var in LAUNCH_VARS:
        value = os.environ.get(var, "")
        if value.isdigit() and int(value) > 1 and comm.size == 1:
            raise LaunchError(
                f"launched as {value} processes ({var}={value}) but MPI sees a world of 1: the "
                "mpiexec does not match the MPI library mpi4py/PETSc use; run './run.sh -n N "
                "SCENE.yaml' or that library's mpiexec")


def keys_markdown() -> str:
    # lazy: each command loads only what it runs (keys, schemes, --help start fast)
    from solver.scene import Scene
    from solver.scene.schema import describe
    lines = ["| key | type | default | meaning |", "|---|---|---|---|"]
    for name, tp, default, doc in describe(Scene):
        cells = [c.replace("|", "\\|") for c in (tp, default, doc)]
        lines.append(f"| `{name}` | {' | '.join(cells)} |")
    return "\n".join(lines)


def schemes_markdown() -> str:
    """The coupling schemes' table (docs/scene.md), from the scheme registry."""
    from solver.scene import registry  # lazy: the registry loads the scheme modules
    lines = ["| `coupling.scheme` | what it is | supports | stability |", "|---|---|---|---|"]
    for name, cls in registry.declared().items():
        cells = [c.replace("|", "\\|") for c in (cls.about, cls.supports, cls.limit)]
        lines.append(f"| `{name}` | {' | '.join(cells)} |")
    return "\n".join(lines)


def update_docs(path: str | None):
    """Replace the generated tables (keys, and coupling schemes where the file
    has their markers) between the markers of ``path``."""
    if not path:
        raise SceneError("keys --update needs the markdown file whose tables it replaces")
    try:
        text = open(path, encoding="utf-8").read()
    except OSError as e:
        raise SceneError(f"keys --update: {path}: {e.strerror}") from None
    if "<!-- keys:" not in text and "<!-- schemes:" not in text:
        raise SceneError(f"keys --update: {path} has no <!-- keys: --> or <!-- schemes: --> "
                         "marker to put the tables between")
    for tag, table in (("keys", keys_markdown), ("schemes", schemes_markdown)):
        text = re.sub(rf"(<!-- {tag}:.*?-->\n).*?(<!-- /{tag} -->)",
                      lambda m: f"{m.group(1)}{table()}\n{m.group(2)}", text, flags=re.S)
    open(path, "w").write(text)


def print_keys(markdown=False):
    # lazy: each command loads only what it runs (keys, schemes, --help start fast)
    from solver.scene import Scene
    from solver.scene.schema import describe
    if markdown:
        print(keys_markdown())
        return
    for name, tp, default, doc in describe(Scene):
        print(f"{name:32s} {tp:28s} default {default:14s} {doc}")


def print_schemes():
    """Integrators and coupling schemes for users: what each is, what it
    supports, its stability limit (the registry's texts, no code notes)."""
    # lazy: each command loads only what it runs (keys, schemes, --help start fast)
    from solver.partitions import integrators
    from solver.scene import Coupling, registry
    from solver.scene.schema import describe
    print("Integrators (partitions[].integrator):")
    for cls in integrators.CATALOGUE:
        print(f"  {cls.about}\n")
    print("Coupling schemes (coupling.scheme):")
    for name, cls in registry.declared().items():
        print(f"  {name}: {cls.about}.\n    supports: {cls.supports}.\n    stability: "
              f"{cls.limit}.\n")
    print("Other coupling keys:")
    for name, tp, default, doc in describe(Coupling):
        if name != "scheme":
            print(f"  coupling.{name}: {tp} (default {default}): {doc}")


def load_on_root(comm, path, overrides, store=None):
    """Rank 0 reads the scene and its mesh or network and binds them (into
    ``store``, the run's ModelData); the other ranks receive the bound scene (they
    never read the mesh)."""
    # lazy: each command loads only what it runs (keys, schemes, --help start fast)
    from solver.collective import on_root
    from solver.model.binding import load_with_text
    return on_root(comm, load_with_text, path, overrides, store)


def main(argv=None) -> int:
    one_blas_thread()                # before anything loads numpy
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] in (["sweep"], ["plot"], ["plan"]):         # their own options and --help
        # lazy: each command loads only what it runs (keys, schemes, --help start fast)
        from solver.tools import plan, plot, sweep
        return {"sweep": sweep, "plot": plot, "plan": plan}[argv[0]].main(argv[1:])
    if not argv or argv[0] == "help" or "--help" in argv or "-h" in argv:
        print(USAGE)
        return 0 if argv else 2
    if argv[0] == "keys":
        if "--update" in argv:
            try:
                rest = argv[argv.index("--update") + 1:]
                update_docs(rest[0] if rest else None)
            except SolverError as e:
                print(f"error: {e}", file=sys.stderr, flush=True)
                return e.exit_code
            return 0
        print_keys(markdown="--markdown" in argv)
        return 0
    if argv[0] == "schemes":
        print_schemes()
        return 0
    # lazy: each command loads only what it runs (keys, schemes, --help start fast)
    from solver.driver.stop import guard_setup, mpi_started
    guard_setup()                    # SIGINT/SIGTERM before stepping: one line, exit 130
    rank, comm = 0, None
    try:
        path, overrides, petsc_args, restart, overwrite = split_args(argv)
        if path is None:
            raise SceneError("no scene file (*.yaml) among the arguments (./run.sh --help lists "
                             "the forms)")
        from mpi4py import MPI  # lazy: importing mpi4py starts MPI; the entry point decides when
        comm = MPI.COMM_WORLD
        rank = comm.rank
        mpi_started()
        check_launch(comm)
        # lazy: each command loads only what it runs (keys, schemes, --help start fast)
        from solver.model.data import ModelData
        from solver.driver.build import run_flags
        store = ModelData(keep=False)          # one run: the mesh goes once the model is built
        scene, effective = load_on_root(comm, path, overrides, store)
        petsc_only, measure_wait = run_flags(petsc_args)
        start_petsc(petsc_only)
        guard_setup()                # again: PETSc's start-up installed its own handlers
        # lazy: each command loads only what it runs (keys, schemes, --help start fast)
        from solver.driver.runner import run, summary
        from solver.driver import provenance
        result = run(scene, comm, log=print, scene_text=open(path, encoding="utf-8").read(),
                     restart=restart, provenance=provenance.attrs(effective, petsc_args),
                     overwrite=overwrite, check_options=True, store=store,
                     measure_wait=measure_wait)
        if rank == 0:
            for line in summary(result, scene.output_file):
                print(line, flush=True)
        return 0
    except SolverError as e:
        # errors of the run are raised on every rank alike (the stages agree
        # collectively): rank 0 says it
        if rank == 0:
            print(f"error: {e}", file=sys.stderr, flush=True)
        if e.exit_code == 130 and comm is not None and comm.size > 1:
            # MPICH's mpiexec, itself interrupted, may report 0 whatever the ranks
            # return: the output is written, so end with MPI_Abort(130)
            # lazy: each command loads only what it runs (keys, schemes, --help start fast)
            from solver.driver.stop import abort
            comm.Barrier()
            abort(comm, None, 130)
        return e.exit_code
    except KeyboardInterrupt as e:
        name = f" ({e.args[0]})" if e.args else ""
        # an interrupt before MPI is up waits for it (stop.mpi_started): comm exists
        return stop_everyone(comm, f"interrupted{name} before stepping; no output written", 130)
    except Exception as e:                      # noqa: BLE001 -- one line, every rank ends
        if os.environ.get("MTS_TRACEBACK"):
            raise
        # lazy: each command loads only what it runs (keys, schemes, --help start fast)
        from solver.errors import describe
        return stop_everyone(comm, f"internal error on rank {rank}: {describe(e)} (set "
                                   "MTS_TRACEBACK=1 for the traceback)", 1)


def stop_everyone(comm, message, code):
    """A problem one rank may have alone: say it once and end every rank (MPI_Abort
    on several ranks, so no rank waits for this one)."""
    if comm is None or comm.size == 1:
        print(f"error: {message}", file=sys.stderr, flush=True)
        return code
    # lazy: each command loads only what it runs (keys, schemes, --help start fast)
    from solver.driver.stop import abort
    if comm.rank != 0:
        time.sleep(0.5)             # rank 0, if it has the same problem, says it first
    abort(comm, message, code)
    return code


def start_petsc(petsc_args):
    """petsc4py with the command line's PETSc options; a PETSc start-up error
    (a missing -options_file, a malformed option) is one line, exit 2."""
    # lazy: each command loads only what it runs (keys, schemes, --help start fast)
    from solver.petscutil import init
    for flag, value in zip(petsc_args, list(petsc_args[1:]) + [None]):
        if flag in ("-options_file", "-options_file_yaml"):
            if value is None or value.startswith("-"):
                raise SceneError(f"{flag} needs a file name")
            if not Path(value).is_file():
                raise SceneError(f"{flag} {value}: file not found")
    if not any(a.startswith("-options_left") for a in petsc_args):
        # PETSc's own end-of-run list looks at rank 0 alone; ours (main) at every rank
        petsc_args = [*petsc_args, "-options_left", "no"]
    try:
        init(petsc_args)
    except Exception as e:                      # noqa: BLE001 -- petsc4py raises PETSc.Error
        detail = " ".join(str(e).split())
        raise SceneError(f"PETSc options {' '.join(petsc_args)}: PETSc could not start "
                         f"({detail})") from None
