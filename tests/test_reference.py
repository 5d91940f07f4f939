"""The modal reference satisfies the equations of motion and its initial state."""
import numpy as np
import pytest

from solver.driver import reference
from solver.model.loads import HalfSine, Sine, Tabulated
from solver.model.arrays import Model, PointLoad

CHAIN = dict(mass=np.array([1.0, 2.0, 3.0]), spring_i=np.array([-1, 0, 1]),
             spring_j=np.array([0, 1, 2]), spring_k=np.array([1.0, 2.0, 3.0]))
FREE = dict(mass=np.array([1.0, 2.0, 3.0]), spring_i=np.array([0, 1]),
            spring_j=np.array([1, 2]), spring_k=np.array([2.0, 3.0]))

CASES = [  # (id, structure, loads given the natural frequencies w, times where f has kinks)
    ("grounded_sine", CHAIN, lambda w: (PointLoad(1, Sine(1.0, np.pi / 2)),), []),
    ("grounded_resonant_sine", CHAIN, lambda w: (PointLoad(0, Sine(0.5, float(w[1]))),), []),
    ("free_free_mixed", FREE, lambda w: (PointLoad(0, Tabulated((0.5, 1.0, 2.0), (0.0, 1.0, 0.0))),
                                         PointLoad(2, HalfSine(2.0, 0.7, 0.3))),
     [0.5, 1.0, 2.0, 0.3]),
    ("free_free_sine", FREE, lambda w: (PointLoad(2, Sine(1.5, 2.0)),), []),
]
U0, V0 = np.array([0.1, 0.0, -0.05]), np.array([0.0, 0.2, 0.0])


def _model(base, make_loads):
    w, _ = reference.modes(Model(dof=1, loads=(), u0=U0, v0=V0, **base))
    return Model(dof=1, loads=make_loads(w), u0=U0, v0=V0, **base)


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_modal_solution_satisfies_the_ode(case):
    _, base, loads, kinks = case
    m = _model(base, loads)
    t = np.linspace(0.0, 5.0, 5001)
    h = t[1] - t[0]
    u, v = reference.modal(m, [0, 1, 2], t)
    assert np.allclose(u[0], m.u0, atol=1e-14) and np.allclose(v[0], m.v0, atol=1e-14)
    f = np.zeros((t.size, 3))
    for load in m.loads:
        f[:, load.dof] += load.function.values(t)
    acc = (u[2:] - 2 * u[1:-1] + u[:-2]) / h ** 2
    res = np.abs(m.mass * acc + u[1:-1] @ m.full_stiffness().T - f[1:-1]).max(axis=1)
    far = np.ones(t.size - 2, bool)
    for tk in kinks:          # the load's slope jumps there: second differences are O(h) off
        far &= np.abs(t[1:-1] - tk) > 3 * h
    assert res[far].max() < 2e-5, res[far].max()
    vel = (u[2:] - u[:-2]) / (2 * h)
    assert np.abs(vel - v[1:-1]).max() < 2e-5


def test_zero_reference_is_said_not_divided_by(tmp_path):
    """A probe the wave has not reached: the 1D reference is zero over the run;
    the summary says so and gives the absolute error (no 1e-315 'relative')."""
    import h5py
    from conftest import raw_scene, run_cli, write_scene
    raw = raw_scene("wave_bar_fem")
    raw["time"]["end"] = 2.0e-5                        # the pulse front travels 10 cm: A is reached, C not
    raw["output"] = {"file": str(tmp_path / "z.h5"), "progress": 0}
    proc = run_cli([write_scene(tmp_path / "z.yaml", raw)])
    assert proc.returncode == 0, proc.stderr
    line = next(l for l in proc.stdout.splitlines() if "probe C: the reference" in l)
    assert "the reference is zero over the run" in line and "max |error|" in line
    a_line = next(l for l in proc.stdout.splitlines() if "probe A: max" in l)
    assert "max relative error" in a_line
    with h5py.File(tmp_path / "z.h5") as f:
        at = f["probes/C"].attrs
        assert at["reference_zero"] and np.isnan(at["max_rel_error"]) and at["max_abs_error"] < 1e-9
