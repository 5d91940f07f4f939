"""Cook's membrane (configs/cook_membrane.yaml; the refinement study:
benchmarks/bench_cook.py, docs/benchmarks/bench_cook.md): quadrilaterals
converge to the codes' 32.25 at nu = 1/3, and at nu = 0.4999 the fully
integrated ones lock while selective integration does not."""
import pytest

from conftest import raw_scene, run_scene


def corner(tmp_path, n, integration, nu):
    raw = raw_scene("cook_membrane")
    raw["model"].update(mesh_parameters={"n": n, "quads": 1}, integration=integration)
    raw["model"]["material"]["nu"] = nu
    raw["output"] = {"file": str(tmp_path / f"{n}{integration}{nu}.h5")}
    return run_scene(raw, tmp_path).probes["C"]["displacement"][0]


def test_cook_membrane_converges_and_selective_does_not_lock(tmp_path):
    """32 x 32: 0.991 (selective) and 0.986 (full) of 32.25 at nu = 1/3; at
    nu = 0.4999 (16 x 16) selective keeps 0.97 of the extrapolated 27.73
    while full integration keeps 0.30 of it."""
    assert corner(tmp_path, 32, "selective", 1 / 3) / 32.25 == pytest.approx(0.991, abs=0.004)
    assert corner(tmp_path, 32, "full", 1 / 3) / 32.25 == pytest.approx(0.986, abs=0.004)
    assert corner(tmp_path, 16, "selective", 0.4999) / 27.73 == pytest.approx(0.972, abs=0.006)
    assert corner(tmp_path, 16, "full", 0.4999) / 27.73 < 0.31
