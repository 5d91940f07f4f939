"""The Python API (solver.load / scene_from_dict / run) and its documented example."""
import importlib.util

import h5py
import numpy as np
import pytest

import solver
from conftest import ROOT, raw_scene
from solver.errors import SceneError


def test_the_documented_example_runs(tmp_path):
    spec = importlib.util.spec_from_file_location("ratio_study", ROOT / "examples" / "ratio_study.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    rows = mod.study(ratios=(1, 5, 20), end=2.0, out_dir=str(tmp_path))
    errors = [err for _, _, err in rows]
    assert errors[0] < errors[1] < errors[2] < 1e-5          # accuracy each speed-up costs
    with h5py.File(tmp_path / "ratio_20.h5") as f:
        assert f.attrs["status"] == "completed"


def test_run_returns_what_the_file_holds(tmp_path):
    raw = raw_scene("six_dof")
    raw["time"]["end"] = 1.0
    raw["output"] = {"file": str(tmp_path / "api.h5"), "progress": 0}
    result = solver.run(solver.scene_from_dict(raw))
    with h5py.File(tmp_path / "api.h5") as f:
        assert np.array_equal(f["probes/x3/displacement"][()], result.probes["x3"]["displacement"])
        assert np.array_equal(f["energy/total"][()], result.energy["total"])
    assert result.status == "completed" and result.partitions["fem"]["steps"] == 2000


def test_bad_overrides_raise_one_line_errors():
    with pytest.raises(SceneError, match=r"partitions\[0\]\.ratio"):
        solver.load(ROOT / "configs" / "six_dof.yaml", ["partitions.fem.ratio=0"])
