"""coupling.scheme gc on 1, 2 and 4 ranks (solver/coupling/gc.py, subdomains.py): the
same scene gives the same output whatever the rank count: to 1e-12 where the
coarse side solves by LU on one rank, to 1e-8 where it is split (CG + GAMG)."""
import h5py
import numpy as np
import pytest

from conftest import run_cases, write_scene

NX, NY = 8, 3                    # columns x rows of masses; node i * NY + j


def grid(end=3.2):
    """A grid of unit masses, springs 1 along x and 0.5 along y, the end
    columns held by springs to the ground; columns 0-3 fine (explicit, h =
    0.2), 4-7 coarse (implicit, 4 h): 3 interface nodes, a load on a fine and
    on an interface node, Rayleigh damping."""
    node = np.arange(NX * NY).reshape(NX, NY)
    springs = [[int(node[i, j]), int(node[i + 1, j]), 1.0] for i in range(NX - 1)
               for j in range(NY)]
    springs += [[int(node[i, j]), int(node[i, j + 1]), 0.5] for i in range(NX)
                for j in range(NY - 1)]
    springs += [["ground", int(node[0, j]), 1.0] for j in range(NY)]
    springs += [[int(node[-1, j]), "ground", 1.0] for j in range(NY)]
    u0 = {int(n): float(np.sin(0.7 * n + 0.3)) for n in range(NX * NY)}
    half = NX * NY // 2
    return {
        "name": "gc_grid", "time": {"end": end, "dt": 0.2},
        "model": {"kind": "network", "masses": [1.0] * (NX * NY), "springs": springs},
        "partitions": [
            {"name": "fine", "method": "fem", "nodes": {"range": [0, half]},
             "integrator": "explicit", "ratio": 1},
            {"name": "coarse", "method": "fem", "nodes": {"range": [half, NX * NY]},
             "integrator": "implicit", "ratio": 4}],
        "coupling": {"scheme": "gc"},
        "damping": {"alpha": 0.01, "beta": 0.01},
        "initial": {"displacement": u0},
        "loads": [{"node": 5, "kind": "sine", "amplitude": 0.3, "omega": 0.9},
                  {"node": half + 1, "kind": "sine", "amplitude": 0.2, "omega": 1.3}],
        "probes": [{"name": f"u{n}", "node": n} for n in (0, 5, half, half + 3, NX * NY - 1)],
        "reference": "none",
        "output": {"energy_every": 1},
    }


# (ranks, --set items, tolerance): sides on 1 + 1 ranks and on 2 + 2 (both split; the
# coarse side solves by CG + GAMG).  1 + 3 agrees too (2e-12), but its 3-rank GAMG costs
# 14 s oversubscribed on 2 cores against 1.8 s for 2 + 2, so it is not run here.
RUNS = {"n2": (2, [], 1e-12),
        "n4": (4, ["partitions.fine.ranks=2", "partitions.coarse.ranks=2"], 1e-8)}


def datasets(path):
    """Every dataset of an output file (name -> array) and its rank count."""
    out = {}
    with h5py.File(path) as f:
        f.visititems(lambda name, obj: out.__setitem__(name, obj[()])
                     if isinstance(obj, h5py.Dataset) else None)
        return out, int(f.attrs["ranks"]), f.attrs["status"]


@pytest.fixture(scope="module")
def gc_runs(tmp_path_factory):
    """The grid on 1 rank, then every case of RUNS, one launch per rank count
    (4 system steps: the 4-rank runs are oversubscribed on 2 cores)."""
    tmp = tmp_path_factory.mktemp("gc_ranks")
    raw = grid()
    launches = {1: [["n1", []]]}
    for name, (n, sets, _) in RUNS.items():
        launches.setdefault(n, []).append([name, sets])
    for n, cases in launches.items():
        argvs = []
        for name, sets in cases:
            raw["output"]["file"] = str(tmp / f"{name}.h5")
            argvs.append([write_scene(tmp / f"{name}.yaml", raw),
                          *sum((["--set", s] for s in sets), [])])
        proc = run_cases(argvs, tmp, n=n if n > 1 else None, timeout=120)
        assert proc.returncode == 0, proc.stderr
    return tmp


@pytest.mark.parametrize("case", sorted(RUNS))
def test_gc_gives_the_one_rank_answer_on_any_rank_count(case, gc_runs):
    """Every output dataset (probe histories, energies) equals the 1-rank
    run's to the tolerance of the coarse solve, relative to its largest value."""
    n, _, tol = RUNS[case]
    one, ranks, status = datasets(gc_runs / "n1.h5")
    assert ranks == 1 and status == "completed"
    other, ranks, status = datasets(gc_runs / f"{case}.h5")
    assert ranks == n and status == "completed"
    assert set(other) == set(one) and len(one) >= 10
    for key, x in one.items():
        y = other[key]
        if key.endswith("peak_rss_mb_per_rank") or x.dtype.kind not in "fi":
            continue
        assert x.shape == y.shape, key
        scale = np.abs(x).max()
        assert np.abs(x - y).max() <= tol * scale, (key, np.abs(x - y).max() / scale)
    assert np.abs(one[f"probes/u{NX * NY // 2}/displacement"]).max() > 0.1    # an interface node
