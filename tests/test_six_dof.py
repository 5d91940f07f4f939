"""Li et al. (2023) §3: six-DOF chain, FEM m1-m3 + DEM m4-m6, against the exact solution."""
import numpy as np
import pytest

from conftest import run_scene


@pytest.mark.parametrize("eta", [1, 2, 5, 10, 20])
def test_default_treatment_error_per_ratio(eta, six_dof, tmp_path):
    six_dof["partitions"][0]["ratio"] = eta
    res = run_scene(six_dof, tmp_path)
    x3 = res.probes["x3"]
    assert res.attrs["external_treatment"] == "taylor"
    assert res.partitions["fem"]["steps"] == round(20.0 / (eta * 1e-4))
    assert res.partitions["dem"]["steps"] == 200000
    assert x3["t"][-1] == pytest.approx(20.0)
    assert x3["attrs"]["max_rel_error"] <= 1e-5, x3["attrs"]
    # the exact solution is not trivially small: x3 swings by order one
    assert np.abs(x3["reference_displacement"]).max() > 0.5


@pytest.mark.parametrize("treatment", ["layers", "literal"])
def test_other_treatments_run_and_are_recorded(treatment, six_dof, tmp_path):
    six_dof["partitions"][0]["ratio"] = 10
    six_dof["time"]["end"] = 5.0
    six_dof["coupling"]["external"] = treatment
    res = run_scene(six_dof, tmp_path)
    assert res.attrs["external_treatment"] == treatment
    assert res.partitions["dem"]["layers"] == (3 if treatment == "layers" else 1)
    assert res.probes["x3"]["attrs"]["max_rel_error"] < 1e-5


def test_energy_balance(six_dof, tmp_path):
    """Kinetic + strain energy equals the external work done (to the scheme's accuracy)."""
    six_dof["time"]["end"] = 10.0
    res = run_scene(six_dof, tmp_path)
    e = res.energy
    scale = np.abs(e["external_work"]).max()
    assert scale > 0.1
    assert np.abs(e["total"] - e["external_work"]).max() < 1e-4 * scale
