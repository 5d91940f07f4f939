"""Several command lines of ``python -m solver`` in one process (one launch):
``[mpiexec -n N] python tests/mpi/cli_cases.py CASES.json``.

CASES.json is a list of ``{"argv": [...], "stdout": PATH or null}``: each case
is ``solver.tools.cli.main(argv)``, run one after the other on every rank, its
rank-0 output written to ``stdout`` when given.  The first case that does not
end with exit code 0 ends the launch with that code (after a line on stderr
naming it).  A launch pays the interpreter, petsc4py, MPI and numba start once
instead of once per case; the runs themselves are the command line's
(tests/conftest.py: run_cases).
"""
import contextlib
import json
import sys


def main(path) -> int:
    from mpi4py import MPI

    from solver.tools.cli import main as cli_main
    rank = MPI.COMM_WORLD.rank
    for i, case in enumerate(json.loads(open(path).read())):
        out = case.get("stdout")
        with open(out, "w") if out and rank == 0 else contextlib.nullcontext() as sink:
            with contextlib.redirect_stdout(sink) if sink else contextlib.nullcontext():
                code = cli_main([str(a) for a in case["argv"]])
        if code != 0:
            print(f"cli_cases: case {i} ({' '.join(map(str, case['argv']))}) ended with exit "
                  f"{code}", file=sys.stderr, flush=True)
            return code
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
