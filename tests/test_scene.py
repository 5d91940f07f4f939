"""Bad input: one line naming the key and value, exit code 2, no traceback, no output."""
import pytest

from conftest import ROOT, raw_scene, run_cli, write_scene

CASES = [
    # (id, mutation of the raw scene, words the message must contain)
    ("unknown_key", lambda r: r.update(partitons=[]), ["partitons", "unknown key", "partitions"]),
    ("misspelled_nested", lambda r: r["time"].update(ed=1.0), ["time.ed", "did you mean 'end'"]),
    ("wrong_type", lambda r: r["time"].update(dt="fast"), ["time.dt", "expected a number", "fast"]),
    ("node_out_of_range", lambda r: r["partitions"][1]["nodes"].append(9),
     ["partitions[1].nodes", "node 9", "out of range"]),
    ("node_owned_twice", lambda r: r["partitions"][0]["nodes"].append(3),
     ["partitions[1].nodes", "node 3", "'fem' and 'dem'"]),
    ("node_owned_by_none", lambda r: r["partitions"][1]["nodes"].remove(5),
     ["partitions", "[5]", "owned by no partition"]),
    ("nonpositive_mass", lambda r: r["model"]["masses"].__setitem__(2, 0),
     ["model.masses[2]", "positive", "0"]),
    ("nonpositive_stiffness", lambda r: r["model"]["springs"][3].__setitem__(2, -1.0),
     ["model.springs[3]", "positive", "-1"]),
    ("nonpositive_step", lambda r: r["time"].update(dt=0.0), ["time.dt", "positive"]),
    ("nonpositive_ratio", lambda r: r["partitions"][0].update(ratio=0),
     ["partitions[0].ratio", "positive", "0"]),
    ("ratio_not_dividing", lambda r: r["partitions"][1].update(ratio=2),
     ["partitions[1].ratio", "2", "does not divide"]),
    ("spring_node_out_of_range", lambda r: r["model"]["springs"].append([5, 6, 1.0]),
     ["model.springs[6]", "node 6", "out of range"]),
    ("probe_node_out_of_range", lambda r: r["probes"][0].update(node=42),
     ["probes[0].node", "42"]),
    ("load_missing_omega", lambda r: r["loads"][0].pop("omega"), ["loads[0].omega", "required"]),
    ("bad_choice", lambda r: r["coupling"].update(external="magic"),
     ["coupling.external", "magic", "taylor"]),
    ("unsupported_combination", lambda r: r["partitions"][0].update(integrator="verlet"),
     ["partitions[0].integrator", "fem", "verlet"]),
    ("end_too_far", lambda r: r["time"].update(end=1e308), ["time.end", "system steps", "at most"]),
    ("end_overflows", lambda r: r["time"].update(end=float("inf")), ["time.end", "finite"]),
    ("empty_scene_name", lambda r: r.update(name=""), ["name", "''", "scene name"]),
    ("scene_name_escapes", lambda r: r.update(name="../x"), ["name", "'../x'"]),
    ("probe_name_breaks_hdf5", lambda r: r["probes"][0].update(name="a/b"),
     ["probes[0].name", "'a/b'"]),
    ("empty_output_file", lambda r: r.update(output={"file": ""}), ["output.file", "file name"]),
    ("empty_network_file", lambda r: r.update(model={"kind": "network", "file": ""}),
     ["model.file", "file name"]),
    ("generator_too_large", lambda r: r.update(model={"kind": "network", "generator": {
        "name": "chain", "n": 10**9, "mass": 1.0, "stiffness": 1.0}}),
     ["model.generator.n", "at most"]),
]


RAW_TEXT = [
    # (id, scene text, words)
    ("duplicate_key", "name: a\nname: b\n", ["line 2", "duplicate key 'name'"]),
    ("alias_bomb", "a: &x [1, 2]\nb: [" + ", ".join(["*x"] * 200) + "]\n", ["alias"]),
    ("deep_nesting", "a: " + "[" * 60 + "]" * 60 + "\n", ["nesting deeper"]),
    ("python_tag", "name: !!python/object/apply:os.system [ls]\n", ["line 1", "python/object"]),
    ("not_a_mapping", "- 1\n- 2\n", ["a scene is a YAML mapping"]),
]


@pytest.mark.parametrize("case", RAW_TEXT, ids=[c[0] for c in RAW_TEXT])
def test_pathological_yaml_is_one_short_line(case, tmp_path):
    _, text, words = case
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    proc = run_cli([path])
    assert proc.returncode == 2
    line, = proc.stderr.strip().splitlines()
    assert line.startswith(f"error: {path}") and len(line) < 400
    for word in words:
        assert word in line, line


def test_scene_that_is_not_utf8(tmp_path):
    path = tmp_path / "latin1.yaml"
    path.write_bytes("name: caf\u00e9\n".encode("latin-1"))
    proc = run_cli([path])
    assert proc.returncode == 2
    assert proc.stderr.strip() == f"error: {path}: not UTF-8 text (byte 0xe9 at offset 9)"


@pytest.mark.parametrize("override, words", [
    ("time.end=!!python/object/apply:os.system [ls]", ["--set time.end", "not valid YAML"]),
    ("=3", ["--set =3", "key.path=value"]),
    ("time..end=3", ["key.path=value"]),
    ("time.end=[1, 2", ["--set time.end", "not valid YAML"]),
    ("loads.0.direction=[0, 0]", ["loads[0].direction", "zero vector"]),
])
def test_bad_overrides_are_one_line(override, words):
    scene = "configs/wave_bar_fem.yaml" if "direction" in override else "configs/six_dof.yaml"
    proc = run_cli([scene, "--set", override])
    assert proc.returncode == 2, proc.stderr
    line, = proc.stderr.strip().splitlines()
    for word in words:
        assert word in line, line


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_bad_scene_is_refused_in_one_line(case, tmp_path):
    _, mutate, words = case
    raw = raw_scene("six_dof")
    out = tmp_path / "out.h5"
    raw["output"] = {"file": str(out)}
    mutate(raw)
    proc = run_cli([write_scene(tmp_path / "bad.yaml", raw)])
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("error: ") and "Traceback" not in proc.stderr
    for word in words:
        assert word in lines[0], f"{word!r} not in {lines[0]!r}"
    assert not out.exists() and not list(tmp_path.glob(".out.h5*"))


def test_missing_scene_file(tmp_path):
    proc = run_cli([tmp_path / "nope.yaml"])
    assert proc.returncode == 2
    assert "nope.yaml" in proc.stderr and "not found" in proc.stderr


def test_override_of_unknown_item(tmp_path):
    proc = run_cli(["configs/six_dof.yaml", "--set", "partitions.solid.ratio=2"])
    assert proc.returncode == 2
    assert "partitions.solid" in proc.stderr and "no item named" in proc.stderr


def test_yaml12_floats_and_overrides():
    from solver.model.binding import load
    scene = load("configs/six_dof.yaml", ["time.dt=2e-4", "partitions.fem.ratio=10",
                                          "coupling.external=literal"])
    assert scene.time.dt == 2e-4
    assert scene.partitions[0].ratio == 10 and scene.system_dt == pytest.approx(2e-3)
    assert scene.coupling.external == "literal"


def test_every_key_is_documented():
    from solver.scene import Scene
    from solver.scene.schema import describe
    rows = describe(Scene)
    names = {r[0] for r in rows}
    assert {"time.dt", "partitions[].ratio", "coupling.external", "guard.energy_bound",
            "loads[].duration", "output.energy_every"} <= names
    assert all(doc for _, _, _, doc in rows)
    docs = (ROOT / "docs" / "scene.md").read_text()
    missing = [n for n in names if f"`{n}`" not in docs]
    assert not missing, f"docs/scene.md does not document {missing}"


def test_unwritable_output_is_refused_before_stepping(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("")                       # a file where a directory is needed
    proc = run_cli(["configs/six_dof.yaml", "--set", f"output.file={blocker}/o.h5"])
    assert proc.returncode == 2
    line, = proc.stderr.strip().splitlines()
    assert line.startswith("error: output.file: cannot write") and str(blocker) in line
    assert "[solver] t =" not in proc.stdout and "system steps" not in proc.stdout


def test_parsing_builds_nothing_binding_reads_the_model(tmp_path, monkeypatch):
    """The scene is configuration: parsing a continuum scene does not touch the
    mesh; binding reads it once and resolves groups and probe points."""
    from solver.model import mesh
    from solver.model import data as model_data
    from solver.errors import SceneError
    from solver.scene.schema import parse
    from solver.model.binding import from_dict
    from solver.scene import Scene
    monkeypatch.chdir(ROOT)
    raw = raw_scene("wave_bar")
    calls = []
    real = mesh.read
    monkeypatch.setattr(mesh, "read", lambda *a, **k: calls.append(a) or real(*a, **k))
    scene = parse(Scene, raw)
    assert calls == [] and any(p.group for p in scene.partitions)
    bound = from_dict(raw)
    assert len(calls) == 1
    assert all(p.group is None and p.nodes for p in bound.partitions)
    n = model_data.n_nodes(model_data.read(bound.model))
    assert sorted(sum((list(p.nodes) for p in bound.partitions), [])) == list(range(n))
    assert all(p.at is not None and 0 <= p.node < n for p in bound.probes)   # at kept: output says where
    raw["model"]["mesh"] = str(tmp_path / "absent.msh")
    parse(Scene, raw)                                   # still only configuration
    with pytest.raises(SceneError, match="model.mesh: .*absent.msh: mesh file not found"):
        from_dict(raw)


@pytest.mark.parametrize("args, message", [
    (["configs/six_dof.yaml", "--restart"], "error: --restart needs the output file of an earlier run"),
    (["configs/six_dof.yaml", "--set"], "error: --set needs key.path=value"),
    (["configs"], "error: no scene file (*.yaml) among the arguments (./run.sh --help lists the forms)"),
])
def test_command_line_mistakes_are_bad_input(args, message):
    proc = run_cli(args)
    assert proc.returncode == 2 and proc.stderr.strip() == message


def test_bound_partitions_hold_their_nodes_as_one_array():
    """Binding gives each partition its node ids as a NodeSet: 8 bytes a node
    when pickled to every rank (a tuple of ints took 36 in memory), read as an
    array, equal to the tuple it replaces, and hashed by the checkpoint
    fingerprint as that tuple was (checkpoints written before still match)."""
    import dataclasses
    import pickle
    import numpy as np
    from solver.driver.state import fingerprint
    from solver.model.binding import from_dict
    from solver.scene.node_set import NodeSet
    scene = from_dict(raw_scene("wave_bar"))
    nodes = [p.nodes for p in scene.partitions]
    assert all(isinstance(n, NodeSet) for n in nodes)
    total = sum(len(n) for n in nodes)
    assert total > 100 and len(pickle.dumps(nodes, protocol=5)) < 8 * total + 400
    back = pickle.loads(pickle.dumps(scene))
    assert [p.nodes for p in back.partitions] == nodes
    assert not np.asarray(back.partitions[0].nodes).flags.writeable
    as_tuples = dataclasses.replace(scene, partitions=tuple(
        dataclasses.replace(p, nodes=tuple(int(i) for i in p.nodes)) for p in scene.partitions))
    assert fingerprint(as_tuples) == fingerprint(scene)
    assert nodes[0] == tuple(np.asarray(nodes[0]).tolist()) and nodes[0] != nodes[1]
