"""Run the benchmarks/bench_*.py in turn (``./run.sh bench [--all]``).

Benchmarks that declare ``SLOW = True`` (tens of minutes, e.g. the transition
scheme's stability study) run only with ``--all``; the others take minutes."""
import runpy
import sys
from pathlib import Path

everything = "--all" in sys.argv[1:]
for path in sorted(Path(__file__).parent.glob("bench_*.py")):
    if not everything and "\nSLOW = True" in path.read_text():
        print(f"== {path.name}: skipped (slow; ./run.sh bench --all runs it)", flush=True)
        continue
    print(f"== {path.name}", flush=True)
    sys.argv = [str(path)]
    runpy.run_path(str(path), run_name="__main__")
