"""A spread of bond strengths (model.lattice.weibull_modulus, seed;
solver/model/strength.py): the factors are Weibull of the stated modulus with
mean 1, a function of the bond alone; under a tension pulse the weak bonds
break first, each at break_strain x its factor, the energy audit closes, and
the same bonds break at the same steps on 1 and 2 ranks; bad keys are refused."""
import h5py
import numpy as np
import pytest

from conftest import refused, run_cli, run_scene, write_scene
from test_bonds import nonlinear

from solver.model.strength import uniform, weibull


@pytest.mark.parametrize("m", [2.0, 5.0, 10.0])
def test_the_factors_are_weibull_with_mean_one(m):
    rng = np.random.default_rng(7)
    i = rng.integers(0, 10 ** 6, 200_000)
    j = i + rng.integers(1, 5, i.size)
    w = weibull(i, j, m, 0)
    assert abs(w.mean() - 1) < 0.005
    s = np.sort(w)
    F = (np.arange(1, s.size + 1) - 0.5) / s.size
    slope = np.polyfit(np.log(s), np.log(-np.log(1 - F)), 1)[0]     # Weibull plot
    assert abs(slope / m - 1) < 0.01
    assert np.array_equal(weibull(j, i, m, 0), w)                     # a bond, either way round
    assert abs(np.corrcoef(w, weibull(i, j, m, 1))[0, 1]) < 0.01      # another seed: another draw
    counts = np.histogram(uniform(np.arange(100_000), np.arange(100_000) + 1, 3), 10)[0]
    assert np.abs(counts / 10_000 - 1).max() < 0.05


def pulse(m=3.0, **over):
    raw = nonlinear(model__lattice__break_strain=3e-4, partitions__0__ratio=1,
                    damping__beta=0.0, **over)
    raw["model"]["lattice"]["weibull_modulus"] = m
    raw["loads"][0]["direction"] = [-1.0, 0.0]
    raw["time"]["end"] = 3.3992e-5                # 2428 steps; uniform bonds break from 31.7 us
    return raw


def test_weak_bonds_break_first_at_their_own_strain(tmp_path):
    res = run_scene(pulse(), tmp_path)
    b = res.broken
    assert len(b) > 50
    t, strain, limit = b[:, 0], b[:, 3], b[:, 4]
    w = weibull(b[:, 6].astype(np.int64), b[:, 7].astype(np.int64), 3.0, 0)
    assert np.array_equal(limit, 3e-4 * w)                  # each at its own critical strain
    assert limit.max() / limit.min() > 3                    # a real spread
    assert np.all(strain > limit)
    assert t.min() < 31.0e-6                                # before the uniform bonds' 31.7 us
    e = res.energy
    released = res.partitions["dem"]["released_energy"]
    work = e["external_work"][-1]
    assert abs(e["total"][-1] + released - work) < 1e-3 * work


def test_the_same_bonds_break_on_one_and_two_ranks(tmp_path):
    broken = {}
    for n in (1, 2):
        raw = pulse()
        raw["reference"] = "none"
        if n == 2:
            raw["partitions"][1]["ranks"] = 2           # the dem partition split over both
        raw["output"] = {"file": str(tmp_path / f"w{n}.h5"), "progress": 0}
        proc = run_cli([write_scene(tmp_path / f"w{n}.yaml", raw)], n=n if n > 1 else None,
                       timeout=300)
        assert proc.returncode == 0, proc.stderr
        assert "x a Weibull factor (modulus 3, mean 1, seed 0" in proc.stdout
        with h5py.File(tmp_path / f"w{n}.h5") as f:
            b = f["broken_bonds"][()]
        broken[n] = b[np.lexsort((b[:, 7], b[:, 6], b[:, 0]))]
    assert broken[1].shape == broken[2].shape
    assert np.array_equal(broken[1][:, [0, 4, 6, 7]], broken[2][:, [0, 4, 6, 7]])
    assert np.abs(broken[1][:, 3] - broken[2][:, 3]).max() < 1e-12


@pytest.mark.parametrize("sets, message", [
    (["model.lattice.weibull_modulus=0"], "model.lattice.weibull_modulus"),
    (["model.lattice.weibull_modulus=-2"], "model.lattice.weibull_modulus"),
    (["model.lattice.weibull_modulus=3"], "model.lattice.weibull_modulus: spreads the bonds' "
     "strengths around break_strain: give break_strain"),
    (["model.lattice.seed=4"], "model.lattice.seed: seeds the strength spread and the random "
     "packing: give weibull_modulus or kind: random"),
])
def test_bad_strength_input(sets, message, tmp_path):
    line = refused("configs/wave_bar_transition.yaml", sets, tmp_path)
    assert message in line, line
