"""Li et al. (2023) §4: the metamaterial chain against the exact solution; the published
step is refused; the monolithic reference agrees with the modal one."""
import numpy as np
import pytest

from conftest import raw_scene, run_cli, run_scene, write_scene
from solver.model import arrays as model_mod
from solver.driver import monolithic
from solver.driver import reference
from solver.model.binding import from_dict

# acceptance limits of the issue (relative L2 error of the probe history)
LIMITS = {5: 1.2e-3, 20: 1.5e-2}


@pytest.mark.parametrize("eta", sorted(LIMITS))
def test_metamaterial_error_against_exact_solution(eta, tmp_path):
    raw = raw_scene("metamaterial")
    raw["partitions"][0]["ratio"] = eta
    raw["reference"] = "modal"            # exact; the fine monolithic run agrees to 1e-6
    res = run_scene(raw, tmp_path)
    err = res.probes["p550"]["attrs"]["rms_rel_error"]
    assert err <= LIMITS[eta], err
    assert res.partitions["dem"]["steps"] == 75000
    # the pulse has reached the probe: the history is not trivially zero
    assert np.abs(res.probes["p550"]["displacement"]).max() > 1e-6


def test_chain_plain_against_exact_solution(tmp_path):
    """The chain without resonators (Li et al. (2023) Fig. 8's comparison) at eta 5."""
    raw = raw_scene("chain_plain")
    raw["reference"] = "modal"
    res = run_scene(raw, tmp_path)
    assert res.probes["p550"]["attrs"]["rms_rel_error"] <= 1.2e-3
    # without resonators the pulse reaches shell 550 earlier (about 44 ms, 50 with them)
    t, u = res.probes["p550"]["t"], res.probes["p550"]["displacement"]
    arrival = t[np.argmax(np.abs(u) > 0.5 * np.abs(u).max())]
    assert 0.040 < arrival < 0.047


def test_published_step_is_refused(tmp_path):
    proc = run_cli(["configs/metamaterial_published.yaml", "--set",
                    f"output.file={tmp_path / 'o.h5'}"])
    assert proc.returncode == 2
    line, = proc.stderr.strip().splitlines()
    assert "partition 'fem'" in line and "step 0.0001 s" in line
    assert "critical step 7.675e-05 s" in line and "2.606e+04 rad/s" in line
    assert not (tmp_path / "o.h5").exists()


def test_monolithic_reference_converges_to_the_modal_one(tmp_path):
    raw = raw_scene("six_dof")
    raw["time"]["end"] = 4.0
    raw["reference"] = {"kind": "monolithic", "dt": 1e-4, "integrator": "verlet"}
    raw["output"] = {"file": str(tmp_path / "o.h5")}
    scene = from_dict(raw)
    t = np.arange(scene.n_system_steps + 1) * scene.system_dt
    mono = monolithic.history(scene, t)["x3"]
    exact, _ = reference.modal(model_mod.build(scene), [2], t)
    assert np.abs(mono - exact[:, 0]).max() < 1e-7 * np.abs(exact).max() * 100
    cached = list((tmp_path / ".reference-cache").iterdir())
    assert len(cached) == 1
    again = monolithic.history(scene, t)["x3"]            # from the cache
    assert np.array_equal(again, mono)
    assert list((tmp_path / ".reference-cache").iterdir()) == cached


def test_unstable_reference_step_is_refused(tmp_path):
    raw = raw_scene("six_dof")
    raw["reference"] = {"kind": "monolithic", "dt": 1.2, "integrator": "verlet"}  # omega*dt 2.3
    raw["time"]["dt"] = 0.1
    raw["time"]["end"] = 21.6                      # 18 system steps of 1.2 s
    raw["partitions"][0]["ratio"] = 12
    raw["output"] = {"file": str(tmp_path / "o.h5")}
    proc = run_cli([write_scene(tmp_path / "s.yaml", raw)])
    assert proc.returncode == 2
    assert "reference.dt" in proc.stderr and "critical step" in proc.stderr
