"""``python -m solver``: see :mod:`solver.tools.cli`."""
import sys

from solver.tools.cli import main

sys.exit(main())
