"""Networks from generators and files; node ranges in partitions."""
import h5py
import numpy as np
import pytest

from conftest import raw_scene, run_cli, write_scene
from solver.model import generators
from solver.model import data as model_data
from solver.errors import SceneError
from solver.model.binding import from_dict


def test_metamaterial_generator_matches_seed_000():
    net = generators.metamaterial(100, 200, 500, 0.05, 0.05, 7.8e6, 2.49e6)
    assert net.mass.size == 1000 and np.all(net.mass == 0.05)
    assert net.stiffness.size == 799 + 1 + 200
    # shell 299 carries resonator 999 on k_s; the right end is grounded by k_n
    k = {(int(i), int(j)): float(s) for i, j, s in zip(net.spring_i, net.spring_j, net.stiffness)}
    assert k[(299, 999)] == 2.49e6 and k[(100, 800)] == 2.49e6 and k[(799, -1)] == 7.8e6
    assert (99, 899) not in k and k[(0, 1)] == 7.8e6
    plain = generators.metamaterial(100, 200, 500, 0.05, 0.05, 7.8e6, 2.49e6, resonators=False)
    assert plain.mass.size == 800 and plain.stiffness.size == 800


def test_chain_generator_ends():
    net = generators.chain(4, 2.0, 3.0, left="fixed", right="fixed")
    assert net.spring_i.tolist() == [-1, 0, 1, 2, 3] and net.spring_j.tolist() == [0, 1, 2, 3, -1]


@pytest.mark.parametrize("suffix", ["npz", "h5"])
def test_network_from_file_runs_like_the_inline_one(suffix, tmp_path):
    raw = raw_scene("six_dof")
    raw["time"]["end"] = 2.0
    net = model_data.read(from_dict(raw).model)
    path = tmp_path / f"net.{suffix}"
    arrays = dict(mass=net.mass, spring_i=net.spring_i, spring_j=net.spring_j, stiffness=net.stiffness)
    if suffix == "npz":
        np.savez(path, **arrays)
    else:
        with h5py.File(path, "w") as f:
            for k, v in arrays.items():
                f[k] = v
    results = []
    for model in (raw["model"], {"kind": "network", "file": str(path)}):
        raw["model"] = model
        raw["output"] = {"file": str(tmp_path / f"o{len(results)}.h5")}
        proc = run_cli([write_scene(tmp_path / "s.yaml", raw)])
        assert proc.returncode == 0, proc.stderr
        results.append(h5py.File(tmp_path / f"o{len(results)}.h5")["probes/x3/displacement"][()])
    assert np.array_equal(results[0], results[1])


BAD_MODELS = [
    ({"kind": "network", "generator": {"name": "lattice"}}, ["model.generator.name", "lattice"]),
    ({"kind": "network", "generator": {"name": "chain", "n": 6, "mass": 1.0}},
     ["model.generator.stiffness", "missing"]),
    ({"kind": "network", "generator": {"name": "chain", "n": 6, "mass": -1.0, "stiffness": 1.0}},
     ["model.generator.mass", "positive"]),
    ({"kind": "network", "file": "nope.npz"}, ["model.file", "nope.npz", "not found"]),
    ({"kind": "network", "masses": [1.0] * 6}, ["model.springs", "together"]),
    ({"kind": "network", "generator": {"name": "chain", "n": 6, "mass": 1.0, "stiffness": 1.0},
      "masses": [1.0] * 6, "springs": [[0, 1, 1.0]]}, ["exactly one", "masses, generator"]),
]


@pytest.mark.parametrize("model,words", BAD_MODELS, ids=range(len(BAD_MODELS)))
def test_bad_models_are_refused(model, words, tmp_path):
    raw = raw_scene("six_dof")
    raw["model"] = model
    proc = run_cli([write_scene(tmp_path / "s.yaml", raw)])
    assert proc.returncode == 2
    line, = proc.stderr.strip().splitlines()
    for w in words:
        assert w in line, line


def test_bad_file_contents_name_the_file(tmp_path):
    path = tmp_path / "net.npz"
    np.savez(path, mass=np.ones(3), spring_i=np.array([0, 1]), spring_j=np.array([1, 7]),
             stiffness=np.ones(2))
    raw = raw_scene("six_dof")
    raw["model"] = {"kind": "network", "file": str(path)}
    raw["partitions"][0]["nodes"] = [0, 1]
    raw["partitions"][1]["nodes"] = [2]
    proc = run_cli([write_scene(tmp_path / "s.yaml", raw)])
    assert proc.returncode == 2
    assert str(path) in proc.stderr and "node 7 out of range" in proc.stderr


@pytest.mark.parametrize("arrays, words", [
    (dict(mass=np.array([1.0, np.nan, 1.0])), ["array mass", "non-finite"]),
    (dict(mass=np.ones((3, 1))), ["array mass", "1-D", "(3, 1)"]),
    (dict(spring_j=np.array([1.0, 2.5])), ["array spring_j", "whole numbers"]),
    (dict(stiffness=np.array(["a", "b"])), ["array stiffness", "dtype"]),
])
def test_bad_file_arrays_name_key_file_and_array(tmp_path, arrays, words):
    path = tmp_path / "net.npz"
    base = dict(mass=np.ones(3), spring_i=np.array([0, 1]), spring_j=np.array([1, 2]),
                stiffness=np.ones(2))
    base.update(arrays)
    np.savez(path, **base)
    raw = raw_scene("six_dof")
    raw["model"] = {"kind": "network", "file": str(path)}
    raw["partitions"][0]["nodes"] = [0, 1]
    raw["partitions"][1]["nodes"] = [2]
    with pytest.raises(SceneError) as e:
        from_dict(raw)
    for w in ["model.file", str(path)] + words:
        assert w in str(e.value)


def test_node_ranges():
    raw = raw_scene("six_dof")
    raw["partitions"][0]["nodes"] = [0, {"range": [1, 3]}]
    raw["partitions"][1]["nodes"] = {"range": [3, 6]}
    scene = from_dict(raw)
    assert scene.partitions[0].nodes == (0, 1, 2) and scene.partitions[1].nodes == (3, 4, 5)
    raw["partitions"][1]["nodes"] = {"range": [5, 3]}
    with pytest.raises(Exception, match=r"partitions\[1\].nodes\[0\].range"):
        from_dict(raw)
