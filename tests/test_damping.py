"""Rayleigh damping: damped free vibration against the exact modal solution,
for each integrator, and the damped stability limit."""
import numpy as np
import pytest

from conftest import raw_scene, run_cli, run_scene, write_scene


def damped(method, integrator, dt, end=20.0, alpha=0.05, beta=0.02):
    raw = raw_scene("six_dof")
    raw["name"] = f"damped_{integrator}"
    raw["time"] = {"end": end, "dt": dt}
    raw["partitions"] = [{"name": "all", "method": method, "nodes": list(range(6)),
                          "integrator": integrator, "ratio": 1}]
    raw["loads"] = []
    raw["initial"] = {"displacement": {5: 1.0}, "velocity": {2: 0.5}}
    raw["damping"] = {"alpha": alpha, "beta": beta}
    raw["output"] = {"file": "x.h5", "energy_every": 10}
    return raw


# (method, integrator, alpha, beta, order): the explicit forms evaluate damping
# forces at a predicted velocity, first order in the terms they cannot solve for
CASES = [("fem", "explicit", 0.05, 0.0, 2), ("fem", "explicit", 0.05, 0.02, 1),
         ("fem", "implicit", 0.05, 0.02, 2), ("dem", "verlet", 0.05, 0.02, 1)]


@pytest.mark.parametrize("method,integrator,alpha,beta,order", CASES)
def test_damped_free_vibration_converges(method, integrator, alpha, beta, order, tmp_path):
    steps = np.array([0.04, 0.02, 0.01])
    errors = [run_scene(damped(method, integrator, dt, alpha=alpha, beta=beta),
                        tmp_path).probes["x3"]["attrs"]["rms_rel_error"] for dt in steps]
    observed = np.polyfit(np.log(steps), np.log(errors), 1)[0]
    assert observed > order - 0.15, (observed, errors)
    assert errors[-1] < 2e-3


def test_damping_dissipates_energy(tmp_path):
    res = run_scene(damped("fem", "implicit", 0.05, end=60.0), tmp_path)
    total = res.energy["total"]
    assert np.all(np.diff(total) <= 1e-12 * total[0]) and total[-1] < 0.1 * total[0]


def test_damping_lowers_the_explicit_critical_step(tmp_path):
    raw = damped("fem", "explicit", 1.0, beta=0.5)          # xi at omega_max ~ 0.47
    raw["output"] = {"file": str(tmp_path / "o.h5")}
    proc = run_cli([write_scene(tmp_path / "s.yaml", raw)])
    assert proc.returncode == 2
    crit = float(proc.stderr.split("critical step ")[1].split(" s")[0])
    from solver.model import arrays as model
    from solver.driver import reference
    from solver.model.binding import from_dict
    w = reference.modes(model.build(from_dict(raw)))[0].max()       # omega_max of the chain
    xi = 0.5 * (0.05 / w + 0.5 * w)
    assert crit == pytest.approx(2 * (np.sqrt(1 + xi ** 2) - xi) / w, rel=1e-3)
