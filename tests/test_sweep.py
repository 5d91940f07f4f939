"""The sweep command writes the error-against-run-time table and plots."""
import csv
import os
import subprocess
import sys

import pytest

from conftest import ROOT


def test_sweep_table(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "solver.tools.sweep", "configs/six_dof.yaml",
                           "--ratios", "1,4", "--treatments", "taylor,literal", "-n", "1,2",
                           "--set", "time.end=0.5", "--out", str(tmp_path)], cwd=ROOT,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    rows = list(csv.DictReader(open(tmp_path / "sweep.csv")))
    assert [(r["ranks"], r["treatment"], r["eta"]) for r in rows] == [
        (n, t, e) for n in "12" for t in ("taylor", "literal") for e in "14"]
    for r in rows:
        assert 0 < float(r["max_rel_error"]) < 1e-6
        assert float(r["stepping_s"]) > 0
        assert int(r["fem_steps"]) == 5000 // int(r["eta"])
    # speed-up of every row against the first point of its variant, from the stepping
    # times written beside it; the error grows with the ratio
    for base, row in ((rows[i], rows[i + 1]) for i in range(0, len(rows), 2)):
        assert float(row["speedup"]) == pytest.approx(
            float(base["stepping_s"]) / float(row["stepping_s"]), rel=1e-9)
        assert float(row["time_ratio"]) == pytest.approx(1 / float(row["speedup"]), rel=1e-9)
        assert float(row["max_rel_error"]) > float(base["max_rel_error"])
    assert (tmp_path / "sweep.png").stat().st_size > 10000
    assert "| ranks | scheme | treatment | η |" in (tmp_path / "sweep.md").read_text()


def test_sweep_over_base_steps_fits_the_order(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "solver.tools.sweep", "configs/five_node.yaml",
                           "--dts", "0.002,0.006,0.01", "--schemes", "staggered,gc,conserving",
                           "-n", "1,2", "--set", "partitions.explicit.beta=0", "--out",
                           str(tmp_path)], cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "skipping" not in proc.stdout                 # every scheme runs on 2 ranks
    orders = {line.split(",", 1)[1].rsplit(":", 1)[0].strip(): float(line.rsplit(":", 1)[1])
              for line in proc.stdout.splitlines() if line.startswith("observed order")}
    for ranks in (1, 2):
        assert abs(orders[f"staggered / layers on {ranks} rank(s)"] - 2.0) < 0.2, orders
        assert abs(orders[f"conserving / - on {ranks} rank(s)"] - 2.0) < 0.2, orders
        assert abs(orders[f"gc / - on {ranks} rank(s)"] - 1.0) < 0.2, orders
    rows = list(csv.DictReader(open(tmp_path / "sweep.csv")))
    assert len(rows) == 18              # (staggered + conserving + gc) x 2 ranks, 3 steps
    err = {(r["scheme"], r["ranks"], r["dt"]): float(r["vector_rel_error"]) for r in rows}
    for dt in ("0.002", "0.006", "0.01"):                 # conserving: same on 1 and 2 ranks
        assert err[("conserving", "1", dt)] == pytest.approx(err[("conserving", "2", dt)], rel=1e-9)
        assert 30 * err[("conserving", "1", dt)] < err[("gc", "1", dt)]   # GC: first order
        assert err[("gc", "1", dt)] == pytest.approx(err[("gc", "2", dt)], rel=1e-9)
    two = [r for r in rows if r["ranks"] == "2"]
    assert all(float(r["implicit_wait_us"]) > 0 and float(r["explicit_wait_us"]) > 0 for r in two)
    assert "eq. 9 error" in (tmp_path / "sweep.md").read_text()


@pytest.mark.parametrize("args, message", [
    (["--ratios", ","], "error: --ratios: expected a comma-separated list, got ','"),
    (["--ratios", "1,x"], "error: --ratios: '1,x' is not a list of whole numbers"),
    (["--dts", "0,1"], "error: --dts: every value must be positive and finite, got '0,1'"),
    (["-n", "0"], "error: -n: every value must be positive and finite, got '0'"),
    (["--treatments", ""], "error: --treatments: expected a comma-separated list, got ''"),
])
def test_sweep_refuses_bad_lists_naming_the_option(args, message, tmp_path):
    proc = subprocess.run([sys.executable, "-m", "solver.tools.sweep", "configs/six_dof.yaml",
                           *args, "--out", str(tmp_path)], cwd=ROOT, capture_output=True,
                          text=True, env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=120)
    assert proc.returncode == 2 and proc.stderr.strip() == message


def test_sweep_ends_with_the_exit_code_of_the_run_it_wraps(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "solver.tools.sweep", "configs/six_dof.yaml",
                           "--ratios", "1", "--set", "time.dt=3", "--set", "time.end=30",
                           "--out", str(tmp_path)],
                          cwd=ROOT, capture_output=True, text=True,
                          env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=120)
    assert proc.returncode == 2                        # the run's: an unstable step
    line, = proc.stderr.strip().splitlines()
    assert line.startswith("error: sweep: run failed") and "unstable" in line


def test_plot_refuses_what_it_cannot_read(tmp_path):
    import h5py
    (tmp_path / "junk.h5").write_text("not hdf5")
    with h5py.File(tmp_path / "foreign.h5", "w") as f:
        f["x"] = [1.0]
    good = tmp_path / "good.h5"
    run = subprocess.run([sys.executable, "-m", "solver", "configs/six_dof.yaml", "--set",
                          "time.end=0.01", "--set", f"output.file={good}"], cwd=ROOT,
                         capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert run.returncode == 0, run.stderr
    (tmp_path / "cut.h5").write_bytes(good.read_bytes()[:2000])
    cases = [([tmp_path / "nope.h5"], "no such output file"),
             ([tmp_path / "junk.h5"], "not a readable HDF5 file"),
             ([tmp_path / "cut.h5"], "not a readable HDF5 file"),
             ([tmp_path / "foreign.h5"], "not an output of this solver (no /energy, status attribute)"),
             ([good, "--probe", "zz"], "no probe 'zz' (it has: x3)")]
    for args, words in cases:
        proc = subprocess.run([sys.executable, "-m", "solver.tools.plot", *map(str, args), "-o",
                               str(tmp_path / "p.png")], cwd=ROOT, capture_output=True, text=True,
                              env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=120)
        assert proc.returncode == 2, (args, proc.stderr)
        line, = proc.stderr.strip().splitlines()
        assert line.startswith(f"error: {args[0]}: ") and words in line, line


def test_sweep_ends_each_ratio_on_a_whole_system_step(tmp_path):
    """A run ends on a whole system step: the sweep ends each ratio on the last
    one before time.end and says so (1.0 s at eta = 3: 3333 steps of 3e-4 s)."""
    proc = subprocess.run([sys.executable, "-m", "solver.tools.sweep", "configs/six_dof.yaml",
                           "--ratios", "2,3", "--set", "time.end=1.0", "--out", str(tmp_path)],
                          cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "η = 3: ends at 0.9999 s (3333 whole system steps of 0.0003 s)" in proc.stdout
    assert "η = 2: ends" not in proc.stdout
    rows = list(csv.DictReader(open(tmp_path / "sweep.csv")))
    assert [int(r["fem_steps"]) for r in rows] == [5000, 3333]
