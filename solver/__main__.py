"""``python -m solver`` and the ``mts-solver`` console script: see :mod:`solver.tools.cli`.

``--version`` prints the package version (``solver.__version__``)."""
import os
import sys


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] in (["--version"], ["-V"]):
        from solver import __version__  # lazy: --version loads nothing else
        print(f"mts-solver {__version__}")
        return 0
    from solver.tools.cli import main as cli_main  # lazy: after the --version answer
    try:
        code = cli_main(argv)
        sys.stdout.flush()
    except BrokenPipeError:      # `keys | head`: the reader left; not an error of ours
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        code = 0
    return code


if __name__ == "__main__":
    sys.exit(main())
