"""Ranks shared by measured cost (``balance: measured``, solver/driver/balance.py):
the assignment from constructed measured costs, the log's walls and waits, and
3-rank runs whose answers equal the estimated runs' (bitwise on the same
assignment, to 1e-12 across assignments)."""
import copy
import re
import subprocess
import sys
import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest

from conftest import ROOT, mpiexec, refused, run_cases, run_cli, write_scene
from solver.driver.balance import cannot_change, decide
from solver.partitions.ranks import assign, measured_cost, waits


# --- the assignment from measured costs ----------------------------------------------

def test_measured_costs_share_the_ranks():
    """Partition 0 takes 2 ms on 1 rank, partition 1 1 ms on each of 5: rank-seconds
    2 and 5 ms, so 6 ranks split 2 + 4 (largest remainder of 6 x 2/7 and 6 x 5/7)."""
    costs = [measured_cost(2e-3, 1), measured_cost(1e-3, 5)]
    assert costs == [2e-3, 5e-3]
    a = assign(6, costs, [100, 100], [None, None], "measured")
    assert a.ranks == ((0, 1), (2, 3, 4, 5))
    assert a.how == "6 rank(s) for 2 partition(s), shared by measured cost"
    assert a.lines(["fem", "dem"])[1:] == [
        "[solver]   fem: ranks 0-1 (2), measured cost 2 ms x ranks per system step (29%)",
        "[solver]   dem: ranks 2-5 (4), measured cost 5 ms x ranks per system step (71%)"]
    # the cap still holds: a partition of 2 nodes takes at most 2 ranks
    assert assign(6, [9e-3, 1e-3], [2, 100], [None, None], "measured").ranks == \
        ((0, 1), (2, 3, 4, 5))


def test_measured_costs_place_shared_ranks():
    """Fewer ranks than partitions: most expensive first onto the least-loaded rank."""
    a = assign(2, [3e-3, 2e-3, 2e-3, 1e-3], [9] * 4, [None] * 4, "measured")
    assert a.ranks == ((0,), (1,), (1,), (0,))
    assert a.how.endswith("placed by measured cost (rank loads 4 ms, 4 ms)")


def test_estimated_lines_are_as_before():
    a = assign(3, [40.0, 8.0], [3, 3], [None, None])
    assert a.lines(["dem", "fem"]) == [
        "[solver] ranks: 3 rank(s) for 2 partition(s), shared by estimated cost",
        "[solver]   dem: ranks 0-1 (2), cost 40 nonzeros x steps per system step (83%)",
        "[solver]   fem: rank 2 (1), cost 8 nonzeros x steps per system step (17%)"]


def test_waits_and_rank_times():
    a = assign(4, [3.0, 1.0], [9, 9], [None, None])           # ranks 0-2 and 3
    times = a.rank_times([2e-3, 5e-3], 4)
    assert times.tolist() == [2e-3, 2e-3, 2e-3, 5e-3]
    assert waits(times).tolist() == [3e-3, 3e-3, 3e-3, 0.0]


class _Spec:
    def __init__(self, name, ranks=None):
        self.name, self.ranks = name, ranks


class _Scene:
    def __init__(self, *specs, steps=5):
        self.partitions, self.balance_steps = specs, steps
        self.coupling = type("C", (), {"scheme": "overlap"})
        self.scheme = type("S", (), {"rides": True})


def test_decide_from_constructed_walls():
    """Estimated: ranks 0-2 for a, rank 3 for b.  Measured: a's pieces 1 ms each,
    b 9 ms: costs 3 and 9 ms x ranks, so a gets 1 rank and b 3; predicted 3 ms on
    every rank, no wait (before: 8 ms on ranks 0-2)."""
    scene = _Scene(_Spec("a"), _Spec("b"))
    before = assign(4, [3.0, 1.0], [50, 50], [None, None])
    walls = [{0: 1e-3}, {0: 1e-3}, {0: 1e-3}, {1: 9e-3}]
    after, lines = decide(scene, before, [50, 50], walls, None, 4)
    assert after.ranks == ((0,), (1, 2, 3)) and after.basis == "measured"
    assert lines == [
        "[solver] balance: measured, each partition's wall per system step over 5 system "
        "step(s) from the initial state (after one to warm up)",
        "[solver]   before: a: ranks 0-2 (3), 1 ms per system step",
        "[solver]   before: b: rank 3 (1), 9 ms per system step",
        "[solver]   before: wait per rank for the slowest 8 / 8 / 8 / 0 ms per system step "
        "(slowest rank 9 ms)",
        "[solver] ranks: 4 rank(s) for 2 partition(s), shared by measured cost",
        "[solver]   a: rank 0 (1), measured cost 3 ms x ranks per system step (25%)",
        "[solver]   b: ranks 1-3 (3), measured cost 9 ms x ranks per system step (75%)",
        "[solver]   after: a: rank 0 (1), predicted 3 ms per system step",
        "[solver]   after: b: ranks 1-3 (3), predicted 3 ms per system step",
        "[solver]   after: predicted wait per rank for the slowest 0 / 0 / 0 / 0 ms per "
        "system step (slowest rank 3 ms)",
        "[solver]   balance: the assignment changed; the partitions are built again on these "
        "ranks"]
    # the slowest piece is the partition's wall; a failure keeps the estimate
    walls = [{0: 1e-3}, {0: 4e-3}, {0: 1e-3}, {1: 1e-3}]
    assert decide(scene, before, [50, 50], walls, None, 4)[0].ranks == before.ranks
    kept, lines = decide(scene, before, [50, 50], walls, "partition 'b': boom", 4)
    assert kept is before and "a partition failed while timed (partition 'b': boom)" in lines[1]


def test_nothing_to_time_where_nothing_can_change():
    class Built:
        assignment = type("A", (), {"ranks": ((0,), (1,))})
        owned_counts = [1999] * 2
    scene = _Scene(_Spec("a"), _Spec("b"))
    assert cannot_change(scene, Built, 1) == "one rank serves every partition"
    assert cannot_change(scene, Built, 2) == "2 ranks for 2 partitions: one rank each"

    class Riding(Built):                  # partitions[].ranks left one partition riding
        assignment = type("A", (), {"ranks": ((0, 1), (0,))})
    assert cannot_change(scene, Riding, 2) is None

    class Large(Built):                   # a cheap partition might ride beside half of it
        owned_counts = [2000] * 2
    assert cannot_change(scene, Large, 2) is None
    assert cannot_change(scene, Built, 3) is None
    assert cannot_change(_Scene(_Spec("a"), _Spec("b"), _Spec("c")), Built, 2) is None   # placement
    assert cannot_change(_Scene(_Spec("a", 1), _Spec("b", 2)), Built, 3) == \
        "partitions[].ranks gives every partition's ranks"

    class Own:
        assignment = None
    assert "places its partitions on ranks itself" in cannot_change(scene, Own, 3)


# --- runs ---------------------------------------------------------------------------

def chain(name, sizes, ratios, dt=1.0e-4, end=2.0, **top):
    """A chain of unit masses on unit springs (fixed left end) cut into
    partitions of ``sizes`` nodes, left to right, alternately fem (explicit)
    and dem (verlet), with ``ratios``; a sine load on the second partition's
    first node and a probe at the last node of every partition."""
    starts = np.concatenate([[0], np.cumsum(sizes)]).tolist()
    parts = [{"name": f"p{k}", "method": "fem" if k % 2 == 0 else "dem",
              "integrator": "explicit" if k % 2 == 0 else "verlet", "ratio": r,
              "nodes": [{"range": [starts[k], starts[k + 1]]}]} for k, r in enumerate(ratios)]
    return {"name": name, "time": {"end": end, "dt": dt},
            "model": {"kind": "network", "generator": {"name": "chain", "n": starts[-1],
                                                       "mass": 1.0, "stiffness": 1.0}},
            "partitions": parts,
            "loads": [{"node": starts[1], "kind": "sine", "amplitude": 1.0, "omega": 3.0}],
            "probes": [{"name": f"x{k}", "node": starts[k + 1] - 1} for k in range(len(sizes))],
            "output": {"progress": 0}, **top}


def histories(path):
    """(probe displacements and velocities and the total energy, ranks per partition)."""
    with h5py.File(path) as f:
        assert f.attrs["status"] == "completed"
        out = {f"{p}/{k}": f[f"probes/{p}/{k}"][()] for p in f["probes"]
               for k in ("displacement", "velocity")}
        out["E"] = f["energy/total"][()]
        ranks = [int(f[f"partitions/{p}"].attrs["ranks"]) for p in sorted(f["partitions"])]
        steps = {p: int(f[f"partitions/{p}"].attrs["steps"]) for p in f["partitions"]}
    return out, ranks, steps


def rel(a, b) -> float:
    scale = np.abs(a).max()
    assert scale > 0
    return float(np.abs(a - b).max() / scale)


def launch(tmp, n, runs):
    """``runs``: {name: raw scene}; one launch on ``n`` ranks (tests/mpi/cli_cases.py),
    each run's output at tmp/NAME.h5 and its log at tmp/NAME.log."""
    cases = []
    for name, raw in runs.items():
        raw = dict(raw, name=name, output={"file": str(tmp / f"{name}.h5"), "progress": 0})
        cases.append(([write_scene(tmp / f"{name}.yaml", raw)], tmp / f"{name}.log"))
    proc = run_cases(cases, tmp, n=n, timeout=300)
    assert proc.returncode == 0, proc.stderr


def waits_in(line) -> tuple[list[float], float]:
    """(wait per rank, slowest rank's time) [ms] of a log line."""
    m = re.search(r"for the slowest ([\d.e+\- /]+) ms per system step \(slowest rank "
                  r"([\d.e+-]+) ms\)", line)
    assert m, line
    return [float(x) for x in m[1].split(" / ")], float(m[2])


def test_three_ranks_two_partitions_same_answers(tmp_path):
    """3 ranks for 2 partitions of 20 nodes (fem 2 steps, dem 1 per system step):
    whichever partition the clock gives the second rank, the histories equal the
    estimated run's to 1e-12, and bitwise the estimated run's with the same ranks
    given (partitions[].ranks); the log's ranks are the output's."""
    base = chain("c", [20, 20], [2, 1], dt=1e-2, end=0.4)
    runs = {"estimated": base, "measured": dict(base, balance="measured")}
    for split in ((1, 2), (2, 1)):
        fixed_ranks = copy.deepcopy(base)
        for part, r in zip(fixed_ranks["partitions"], split):
            part["ranks"] = r
        runs[f"fixed{split[0]}{split[1]}"] = fixed_ranks
    launch(tmp_path, 3, runs)
    est, est_ranks, _ = histories(tmp_path / "estimated.h5")
    got, got_ranks, steps = histories(tmp_path / "measured.h5")
    # a cheap partition may ride on a rank of the other's (ranks add up to 4):
    # partitions[].ranks cannot ask for that, so there is no bitwise twin to read
    rides = sum(got_ranks) > 3
    same = None if rides else histories(tmp_path / f"fixed{got_ranks[0]}{got_ranks[1]}.h5")[0]
    log = (tmp_path / "measured.log").read_text()
    assert steps == {"p0": 20, "p1": 40}                   # the timed steps are not counted
    assert "[solver] balance: measured, each partition's wall per system step over 5" in log
    for name, r in zip(("p0", "p1"), est_ranks):
        assert f"[solver]   before: {name}: " in log and f"({r}), " in log
    for name, r in zip(("p0", "p1"), got_ranks):
        assert re.search(rf"after: {name}: ranks? [\d-]+ \({r}\), predicted", log), log
    changed = got_ranks != est_ranks
    assert ("the assignment changed" in log) == changed, log
    assert ("the assignment is unchanged" in log) == (not changed), log
    for key in est:
        assert same is None or np.array_equal(got[key], same[key]), key
        assert rel(est[key], got[key]) <= 1e-12, key


@pytest.fixture(scope="module")
def placements(tmp_path_factory):
    """2 ranks for 3 partitions (fewer ranks than partitions: placement by cost),
    two scenes by estimated and by measured cost, in one launch.
    moved: p0 fem 6000 nodes, 1 step per system step; p1 dem 2 particles, 2000
    steps; p2 fem 10 nodes, 1 step.  The estimate (18000, 10000 and 30 nonzeros x
    steps) puts p0 alone on rank 0; the clock (one MatMult against 2000 Verlet
    steps) puts p1 alone there.
    kept: p0 and p2 fem 10 nodes, 1 step; p1 dem 3000 particles, 100 steps: p1
    alone on rank 0 both ways."""
    tmp = tmp_path_factory.mktemp("placements")
    scenes = {"moved": chain("m", [6000, 2, 10], [2000, 1, 2000], end=4.0),
              "kept": chain("k", [10, 3000, 10], [100, 1, 100], end=0.2)}
    runs = {}
    for name, raw in scenes.items():
        runs[f"{name}_estimated"] = raw
        runs[f"{name}_measured"] = dict(raw, balance="measured", balance_steps=10)
    launch(tmp, 2, runs)
    return tmp


def test_measured_placement_moves_partitions(placements):
    est, est_ranks, _ = histories(placements / "moved_estimated.h5")
    got, got_ranks, steps = histories(placements / "moved_measured.h5")
    log = (placements / "moved_measured.log").read_text()
    assert est_ranks == got_ranks == [1, 1, 1]
    assert steps == {"p0": 20, "p1": 40000, "p2": 20}
    est_log = (placements / "moved_estimated.log").read_text()
    assert "[solver]   p0: rank 0 (1), cost 1.8e+04 nonzeros" in est_log
    assert "[solver]   p1: rank 1 (1), cost 1.2e+04 nonzeros" in est_log
    assert "[solver]   before: p0: rank 0 (1)" in log and "[solver]   before: p1: rank 1 (1)" in log
    assert "[solver]   after: p1: rank 0 (1), predicted" in log, log
    assert "[solver]   after: p0: rank 1 (1), predicted" in log, log
    assert "the assignment changed; the partitions are built again on these ranks" in log
    before = next(line for line in log.splitlines() if "before: wait per rank" in line)
    after = next(line for line in log.splitlines() if "after: predicted wait per rank" in line)
    (b, b_slowest), (a, a_slowest) = waits_in(before), waits_in(after)
    assert len(b) == len(a) == 2 and b[0] > 0 and b[1] == 0       # rank 1 (p1) the slowest
    assert a_slowest <= b_slowest                                # the slowest rank is faster
    for key in est:
        assert rel(est[key], got[key]) <= 1e-12, key


def test_measured_placement_kept_restores_the_initial_state(placements):
    est, est_ranks, _ = histories(placements / "kept_estimated.h5")
    got, got_ranks, steps = histories(placements / "kept_measured.h5")
    log = (placements / "kept_measured.log").read_text()
    assert est_ranks == got_ranks == [1, 1, 1]
    assert steps == {"p0": 20, "p1": 2000, "p2": 20}
    assert "[solver]   after: p1: rank 0 (1), predicted" in log, log
    assert "the assignment is unchanged; the run starts from the initial state put back" in log
    for key in est:
        assert np.array_equal(est[key], got[key]), key     # the calibration left no trace


def test_nothing_timed_on_one_rank_or_one_rank_each(tmp_path):
    raw = chain("one", [10, 10], [10, 1], end=0.01, balance="measured")
    raw["output"]["file"] = str(tmp_path / "one.h5")
    path = write_scene(tmp_path / "one.yaml", raw)
    proc = run_cli([path])
    assert proc.returncode == 0, proc.stderr
    assert ("[solver] balance: measured: nothing to time, one rank serves every partition; "
            "the ranks stay as estimated") in proc.stdout
    proc = run_cli([path], n=2)
    assert proc.returncode == 0, proc.stderr
    assert "[solver] balance: measured: nothing to time, 2 ranks for 2 partitions: one rank " \
           "each; the ranks stay as estimated" in proc.stdout


@pytest.mark.parametrize("item,words", [
    ("balance=fast", "balance: 'fast' is not one of"),
    ("balance_steps=0", "balance_steps"),
])
def test_bad_balance_is_refused(item, words, tmp_path):
    line = refused("configs/six_dof.yaml", [item], tmp_path)
    assert words in line, line


def test_constructed_walls_on_three_ranks(tmp_path):
    """tests/mpi/mpi_balance.py under mpiexec -n 3: the clock's walls replaced by
    constructed ones, a split partition rebuilt on fewer ranks or kept with its
    initial state put back; every test passes on every rank."""
    path = "tests/mpi/mpi_balance.py"
    report = tmp_path / "junit-{rank}.xml"
    proc = subprocess.run([mpiexec(), "-n", "3", sys.executable, "-c",
                           "import sys, pytest; from mpi4py import MPI; sys.exit(pytest.main("
                           f"['-q', '-p', 'no:cacheprovider', '{path}', '--junitxml', "
                           f"'{report}'.format(rank=MPI.COMM_WORLD.rank)]))"],
                          cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    for rank in range(3):
        suite = ET.parse(str(report).format(rank=rank)).getroot().find("testsuite")
        counts = {k: int(suite.get(k)) for k in ("tests", "failures", "errors", "skipped")}
        assert counts == {"tests": 2, "failures": 0, "errors": 0, "skipped": 0}, (rank, counts)
