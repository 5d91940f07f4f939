"""``python -m solver``: see :mod:`solver.tools.cli`."""
import os
import sys

from solver.tools.cli import main

try:
    code = main()
    sys.stdout.flush()
except BrokenPipeError:          # `keys | head`: the reader left; not an error of ours
    os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    code = 0
sys.exit(code)
