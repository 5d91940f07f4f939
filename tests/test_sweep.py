"""The sweep command writes the error-against-run-time table and plots."""
import csv
import subprocess
import sys

import pytest

from conftest import ROOT


def test_sweep_table(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "solver.tools.sweep", "configs/six_dof.yaml",
                           "--ratios", "1,4", "--treatments", "taylor,literal", "-n", "1,2",
                           "--set", "time.end=1.0", "--out", str(tmp_path)], cwd=ROOT,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    rows = list(csv.DictReader(open(tmp_path / "sweep.csv")))
    assert [(r["ranks"], r["treatment"], r["eta"]) for r in rows] == [
        (n, t, e) for n in "12" for t in ("taylor", "literal") for e in "14"]
    for r in rows:
        assert 0 < float(r["max_rel_error"]) < 1e-6
        assert float(r["stepping_s"]) > 0
        assert int(r["fem_steps"]) == 10000 // int(r["eta"])
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
                           "--dts", "0.002,0.006,0.01", "--schemes", "staggered,gc", "-n", "1,2",
                           "--out", str(tmp_path)], cwd=ROOT, capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "skipping gc on 2 ranks" in proc.stdout
    orders = {line.split(",")[1].split(" on")[0].strip(): float(line.rsplit(":", 1)[1])
              for line in proc.stdout.splitlines() if line.startswith("observed order")}
    assert abs(orders["staggered / layers"] - 2.0) < 0.2 and abs(orders["gc / layers"] - 1.0) < 0.2
    rows = list(csv.DictReader(open(tmp_path / "sweep.csv")))
    assert len(rows) == 9                                  # staggered x 2 ranks + gc x 1, 3 steps
    two = [r for r in rows if r["ranks"] == "2"]
    assert all(float(r["implicit_wait_us"]) > 0 and float(r["explicit_wait_us"]) > 0 for r in two)
    assert "eq. 9 error" in (tmp_path / "sweep.md").read_text()
