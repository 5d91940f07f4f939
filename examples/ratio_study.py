"""Accuracy against speed-up from a script: six_dof at several step ratios.

    .venv/bin/python examples/ratio_study.py                    (from the checkout)
    mpiexec.mpich -n 2 .venv/bin/python examples/ratio_study.py (the same on 2 ranks)

(``./run.sh install`` first, once: it builds .venv.)  It writes
results/ratio_<eta>.h5 under the working directory and prints, per ratio, the
stepping wall time and the largest error of probe x3 against the exact
solution.
"""
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import solver  # noqa: E402


def study(ratios=(1, 5, 20), end=4.0, out_dir="results", comm=None):
    rows = []
    for eta in ratios:
        scene = solver.load(Path(__file__).parents[1] / "configs" / "six_dof.yaml",
                            [f"partitions.fem.ratio={eta}", f"time.end={end}",
                             f"output.file={out_dir}/ratio_{eta}.h5", "output.progress=0"])
        result = solver.run(scene, comm=comm)
        x3 = result.probes["x3"]
        err = np.abs(x3["displacement"] - x3["reference_displacement"]).max() / \
            np.abs(x3["reference_displacement"]).max()
        rows.append((eta, result.attrs["stepping_wall_time"], err))
    return rows


if __name__ == "__main__":
    for eta, wall, err in study():
        print(f"eta {eta:3d}: stepping {wall:.3f} s, max relative error {err:.2e}")
