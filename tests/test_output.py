"""HDF5 layout, and atomic writing: nothing at the final path until complete."""
import signal
import subprocess
import sys
import time

import h5py
from pathlib import Path
import numpy as np

from conftest import ROOT, raw_scene, run_cli, write_scene


def test_output_layout(tmp_path):
    raw = raw_scene("six_dof")
    raw["time"]["end"] = 2.0
    out = tmp_path / "sub" / "o.h5"
    raw["output"] = {"file": str(out)}
    proc = run_cli([write_scene(tmp_path / "s.yaml", raw)])
    assert proc.returncode == 0, proc.stderr
    assert "max relative error" in proc.stdout and str(out) in proc.stdout
    with h5py.File(out) as f:
        a = f.attrs
        assert a["scene"] == "six_dof" and a["status"] == "completed" and a["ranks"] == 1
        assert a["external_treatment"] == "taylor" and a["wall_time"] > 0
        assert "six_dof" in a["scene_yaml"]
        assert f["partitions/fem"].attrs["steps"] == 4000
        assert f["partitions/dem"].attrs["steps"] == 20000
        assert f["partitions/dem"].attrs["wall_time"] > 0
        assert a["steps_fem"] == 4000 and a["steps_dem"] == 20000 and a["wall_time_fem"] > 0
        t = f["probes/x3/t"][()]
        assert t.shape == (4001,) and np.isclose(t[-1], 2.0)
        assert f["probes/x3/displacement"].shape == f["probes/x3/velocity"].shape == t.shape
        assert f["probes/x3"].attrs["max_rel_error"] < 1e-6
        for k in ("t", "kinetic", "strain", "external_work", "total"):
            assert f[f"energy/{k}"].shape == f["energy/t"].shape
    assert sorted(p.name for p in out.parent.iterdir()) == ["o.h5"]


def test_interrupted_run_leaves_no_output(tmp_path):
    raw = raw_scene("six_dof")
    raw["time"]["end"] = 5000.0
    out = tmp_path / "o.h5"
    raw["output"] = {"file": str(out), "progress": 0.2}
    proc = subprocess.Popen([sys.executable, "-m", "solver", str(write_scene(tmp_path / "s.yaml", raw))],
                            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        for line in proc.stdout:                   # wait until it is stepping
            if line.startswith("[solver] t ="):
                break
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        proc.kill()
    time.sleep(0.1)
    assert not out.exists() and list(tmp_path.glob("*.h5*")) == []


def test_plot_command_on_completed_and_failed_runs(tmp_path):
    raw = raw_scene("six_dof")
    raw["time"]["end"] = 2.0
    raw["output"] = {"file": str(tmp_path / "ok.h5")}
    assert run_cli([write_scene(tmp_path / "ok.yaml", raw)]).returncode == 0
    raw["time"] = {"end": 500.0, "dt": 0.25}
    raw["guard"] = {"stable_step": False}
    raw["output"] = {"file": str(tmp_path / "bad.h5")}
    assert run_cli([write_scene(tmp_path / "bad.yaml", raw)]).returncode == 3
    for name in ("ok", "bad"):
        proc = subprocess.run([sys.executable, "-m", "solver.tools.plot", str(tmp_path / f"{name}.h5")],
                              cwd=ROOT, capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr
        assert (tmp_path / f"{name}.png").stat().st_size > 20000
    proc = subprocess.run([sys.executable, "-m", "solver.tools.plot", str(tmp_path / "none.h5")],
                          cwd=ROOT, capture_output=True, text=True)
    assert proc.returncode == 2 and "none.h5" in proc.stderr


def test_output_says_where_it_came_from(tmp_path):
    """The effective scene (after --set), the PETSc options, versions and commit
    are stored; the summary names every file written (fields included)."""
    import json

    import h5py
    import yaml
    out = tmp_path / "p.h5"
    proc = run_cli(["configs/wave_bar_fem.yaml", "--set", f"output.file={out}", "--set",
                    "time.end=4e-7", "--set", "output.fields.every=10", "--set", "reference=none",
                    "-fem_mat_type", "baij"])
    assert proc.returncode == 0, proc.stderr
    with h5py.File(out) as f:
        effective = yaml.safe_load(f.attrs["scene_effective_yaml"])
        assert effective["time"]["end"] == 4e-7 and effective["output"]["fields"] == {"every": 10}
        assert "end: 5.5e-5" in f.attrs["scene_yaml"]             # the file as written
        assert f.attrs["petsc_options"] == "-fem_mat_type baij"
        versions = json.loads(f.attrs["versions"])
        assert versions["PETSc"].startswith("3.") and versions["numpy"][0].isdigit()
        assert f.attrs["commit"]
        fields = list(f.attrs["field_files"])
    assert [Path(x).name for x in fields] == ["p_fields.xdmf", "p_fields.h5"]
    assert all(Path(x).is_file() for x in fields)
    with h5py.File(fields[1]) as f:                   # meshio's data0, data1, ... carry names
        labels = {k: dict(f[k].attrs) for k in f}
    names = sorted(l["name"] for l in labels.values())
    assert names == ["cells", "displacement", "displacement", "displacement", "points", "stress",
                     "stress", "stress", "velocity", "velocity", "velocity"]
    assert sorted({l["time"] for l in labels.values() if "time" in l}) == [0.0, 2e-7, 4e-7]
    for name in fields:
        assert f"[solver]   fields: {name}" in proc.stdout


def test_peak_memory_is_the_runs_own_not_its_parents():
    """A run started by a large process (a sweep, a benchmark) reports its own
    peak resident memory: Linux carries getrusage's ru_maxrss across exec, so a
    child of a 600 MB parent read 600 MB there; VmHWM is the program's own."""
    from solver.driver.report import peak_rss_mb
    held = np.ones(80_000_000)                                  # 640 MB in this process
    held[::512] = 2.0                                           # touched: resident
    probe = ("import resource; from solver.driver.report import peak_rss_mb; "
             "print(peak_rss_mb(), resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         cwd=ROOT, timeout=60)
    own, inherited = map(float, out.stdout.split())
    assert peak_rss_mb() > 600
    assert own < 300, (own, inherited)
    del held
