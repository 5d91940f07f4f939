"""Scene-level refusals found by the hardening review: an end that is not a
whole number of system steps, scheme x model combinations that failed late,
a lattice that does not tile its transition band, --set paths into lists,
the key and scheme listings, echoed values clipped, bodies with nothing to
step and absurdly thin shells."""
import copy
import time

import numpy as np
import pytest

from conftest import ROOT, raw_scene, refused, run_cli
from solver.errors import SceneError


def parsed(raw):
    """Scene.validate alone (no mesh or network is read)."""
    from solver.scene import Scene
    from solver.scene.schema import parse
    return parse(Scene, copy.deepcopy(raw))


def network(end, dt, ratio=1):
    return {"name": "n", "time": {"end": end, "dt": dt},
            "model": {"kind": "network", "masses": [1.0, 1.0],
                      "springs": [["ground", 0, 1.0], [0, 1, 1.0]]},
            "partitions": [{"name": "a", "method": "fem", "nodes": [0], "integrator": "explicit",
                            "ratio": ratio},
                           {"name": "b", "method": "dem", "nodes": [1], "integrator": "verlet",
                            "ratio": 1}]}


# --- 1. time.end: a whole number of system steps, or refused ------------------

@pytest.mark.parametrize("end, dt, ratio, steps", [
    (0.1, 1e-3, 1, 100), (0.3, 0.1, 1, 3), (0.7, 1e-7, 1, 7_000_000), (5.5e-5, 2e-8, 10, 275),
    (9.0, 1e-3, 3, 3000), (1.0299968e-2, 5.6e-8, 4, 45982), (7.4984e-5, 1.4e-8, 4, 1339), (0.075, 1e-6, 5, 15000)])
def test_ends_on_whole_system_steps_run_all_of_them(end, dt, ratio, steps):
    assert parsed(network(end, dt, ratio)).n_system_steps == steps


def test_every_multiple_of_the_system_step_is_accepted():
    """end = n x (ratio x dt) as a user would type it (a decimal) passes for
    random n, dt and ratio, with exactly n steps; n + 1/2 is refused."""
    rng = np.random.default_rng(1)
    for _ in range(300):
        n, ratio = int(rng.integers(1, 10**6)), int(rng.integers(1, 50))
        dt = float(f"{rng.uniform(1, 10):.3f}e{int(rng.integers(-9, 0))}")
        end = float(f"{n * ratio * dt:.15g}")
        assert parsed(network(end, dt, ratio)).n_system_steps == n
        with pytest.raises(SceneError, match="time.end"):
            parsed(network((n + 0.5) * ratio * dt, dt, ratio))


def test_long_runs_get_no_looser_tolerance():
    """At 9e8 steps a relative 1e-9 would be most of a step: the tolerance is
    at most 1e-3 of a step (a decimal end's rounding is ~1e-7 of one there)."""
    assert parsed(network(0.900000001, 1e-9)).n_system_steps == 900_000_001
    with pytest.raises(SceneError, match=r"time.end: 0.90000000101 s is 900000001.01 system steps"):
        parsed(network(0.90000000101, 1e-9))


def test_end_between_system_steps_is_refused_with_the_nearest_ends(tmp_path):
    """wave_bar_mts at eta = 100: 5.5e-5 s is 27.5 system steps of 2e-6 s (the
    run used to stop at 5.4e-5 s without a word)."""
    line = refused("configs/wave_bar_mts.yaml", ["partitions.coarse.ratio=100"], tmp_path)
    assert line == ("error: configs/wave_bar_mts.yaml: time.end: 5.5e-05 s is 27.5 system steps "
                    "of 2e-06 s (time.dt x ratio 100); a run ends on a whole system step: use "
                    "5.4e-05 (27 steps) or 5.6e-05 (28 steps)"), line


def test_shipped_configs_end_on_a_system_step():
    from solver.scene.file import anchor_paths, yaml_load
    for path in sorted((ROOT / "configs").glob("*.yaml")):
        scene = parsed(anchor_paths(yaml_load(path.read_text()), path.parent))
        if scene.partitions == "auto":      # the levels make the system step (test_levels.py)
            continue
        if scene.analysis == "static":      # no step at all
            continue
        assert abs(scene.n_system_steps * scene.system_dt - scene.time.end) \
            <= 1e-9 * scene.time.end, path.name


# --- 2. scheme x model kind: refused when the scene is read -------------------

@pytest.mark.parametrize("config, sets, words", [
    ("wave_bar_mts", ["coupling.scheme=gc"], "coupling.scheme: gc supports network models only"),
    ("u_tube", ["coupling.scheme=gc"], "coupling.scheme: gc supports network models only"),
    ("laser_disc", ["coupling.scheme=conserving",
                    "partitions=[{name: f, method: fem, group: solid, integrator: explicit, "
                    "beta: 0.0, ratio: 1}, {name: c, method: fem, group: solid, "
                    "integrator: implicit, ratio: 2}]"],
     "coupling.scheme: conserving couples linear partitions without heat"),
])
def test_scheme_the_model_cannot_take_is_refused_before_set_up(config, sets, words, tmp_path):
    from solver.scene.file import apply_override
    raw = raw_scene(config)
    for s in sets:
        apply_override(raw, s)
    with pytest.raises(SceneError, match=words):          # validation alone: no mesh read
        parsed(raw)
    t0 = time.perf_counter()
    line = refused(f"configs/{config}.yaml", sets, tmp_path)
    assert words in line and time.perf_counter() - t0 < 10, line


def test_conserving_with_nonlinear_bonds_and_shells_with_heat_are_refused_on_reading():
    raw = raw_scene("wave_bar_mts")
    raw["coupling"] = {"scheme": "conserving"}
    raw["model"]["lattice"] = {"region": "dem", "spacing": 2e-4, "geometry": "nonlinear"}
    with pytest.raises(SceneError, match="coupling.scheme: conserving couples linear partitions; "
                                         "model.lattice.geometry is nonlinear"):
        parsed(raw)
    raw = raw_scene("plate_shell")
    raw["heat"] = {"conductivity": 1.0, "specific_heat": 1.0, "step": 1e-3, "every": 1}
    with pytest.raises(SceneError, match="heat: models with shells carry no heat"):
        parsed(raw)


# --- 3. a lattice that does not tile the transition band ----------------------

def test_spacing_that_does_not_tile_the_band_is_refused(tmp_path):
    line = refused("configs/wave_bar_transition.yaml", ["model.lattice.spacing=3e-4"], tmp_path)
    assert ("model.lattice.spacing: 0.0003 m does not tile the transition zone: band and region "
            "together (band 'band', region 'dem') is 0.004 m wide in x, 13.33 spacings, so the "
            "lattice stops 0.0001 m short of its edge; spacings that tile every width: "
            "0.000266667 or 0.0004 m") in line, line


def test_tiling_rule_checks_band_and_region_widths():
    from solver.model.transition import _check_tiling, tiling_spacings

    class Lat:
        spacing, transition, region = 0.1, "band", "dem"
    zone = np.array([[0.0, 0.0], [1.0, 0.5]])
    _check_tiling(Lat, zone, np.array([[0.2, 0.0], [0.7, 0.5]]))       # 10 x 5, 2 | 5 | 3
    with pytest.raises(SceneError, match=r"the band below the region \(band 'band', region "
                                         r"'dem'\) is 0.25 m wide in x, 2.5 spacings"):
        _check_tiling(Lat, zone, np.array([[0.25, 0.0], [0.75, 0.5]]))
    below, above = tiling_spacings([1.0, 0.25, 0.5, 0.25], 0.1)
    assert below == pytest.approx(0.25 / 3) and above == pytest.approx(0.125)


# --- 4. --set into lists names what is there -----------------------------------

@pytest.mark.parametrize("item, message", [
    ("partitions.femm.ratio=2", "--set partitions.femm: no item named 'femm' (2 items: index "
                                "0-1 or a name: 'fem', 'dem')"),
    ("loads.7.amplitude=2", "--set loads.7: index 7 out of range (1 item: index 0)"),
    ("probes.name=x", "--set probes.name: no item named 'name' (3 items: index 0-2 or a name: "
                      "'A', 'B', 'C')"),
    ("partitions.--1.ratio=2", "--set partitions.--1: no item named '--1'"),
])
def test_set_into_a_list_lists_its_items(item, message, tmp_path):
    line = refused("configs/wave_bar.yaml", [item], tmp_path)
    assert message in line, line


def test_set_into_a_node_mapping_takes_the_node_id():
    from solver.scene.file import apply_override
    raw = network(1.0, 1e-3)
    raw["initial"] = {"displacement": {1: 0.5}}
    apply_override(raw, "initial.displacement.1=0.25")
    apply_override(raw, "initial.velocity.0=2.0")
    scene = parsed(raw)
    assert scene.initial.displacement == {1: 0.25} and scene.initial.velocity == {0: 2.0}


# --- 5. keys once, schemes for users -------------------------------------------

def test_keys_are_listed_once_and_docs_table_is_current():
    from solver.scene import Scene
    from solver.scene.schema import describe
    from solver.tools.cli import keys_markdown
    names = [row[0] for row in describe(Scene)]
    assert len(names) == len(set(names))
    assert [n for n in names if n.startswith("reference")] == [
        "reference", "reference.dt", "reference.integrator", "reference.cache",
        "reference.length", "reference.load"]
    assert keys_markdown() in (ROOT / "docs" / "scene.md").read_text()


def test_schemes_prints_what_each_scheme_is_supports_and_its_limit():
    from solver.coupling.schemes import ABOUT, LIMIT, SUPPORT
    from solver.partitions import integrators
    proc = run_cli(["schemes"])
    assert proc.returncode == 0
    out = proc.stdout
    assert set(ABOUT) == set(SUPPORT) == set(LIMIT) == {
        "overlap", "staggered", "gc", "conserving", "transition"}
    for name in SUPPORT:
        assert f"  {name}: {ABOUT[name]}.\n    supports: {SUPPORT[name]}.\n    stability: " in out
    assert "predictor 1.15, linear 1.15, velocity 0.65, hold 0.2" in out
    for cls in integrators.CATALOGUE:                     # user text, not the docstrings
        assert cls.about in out and cls.__doc__.strip().splitlines()[-1].strip() not in out
    assert "``" not in out and "typo" not in out


# --- 6. echoed values are clipped -----------------------------------------------

def bomb_text(levels=9):
    """A YAML flow list of 10^(levels+1) ones from 9 x levels aliases (anchors
    defined where first used)."""
    value = "[&b0 [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]" + ", *b0" * 9 + "]"
    for k in range(1, levels):
        value = f"[&b{k} {value}" + f", *b{k}" * 9 + "]"
    return value


def repr_length(levels=9):
    """len(repr()) of that list: a list of n items of length L is 2 + n L + 2 (n - 1)."""
    length = 2 + 10 * 1 + 2 * 9
    for _ in range(levels):
        length = 2 + 10 * length + 2 * 9
    return length


def test_alias_bomb_as_time_end_is_clipped(tmp_path):
    """The issue's case: time.end is an alias bomb (81 alias uses, 10^10 ones):
    one short line, the value's first 200 characters and its length."""
    from solver.scene.file import yaml_load
    assert len(repr(yaml_load(bomb_text(3)))) == repr_length(3)
    path = tmp_path / "end_bomb.yaml"
    path.write_text((ROOT / "configs" / "six_dof.yaml").read_text().replace(
        "time: {end: 20.0,", f"time: {{end: {bomb_text()},"))
    t0 = time.perf_counter()
    proc = run_cli([path, "--set", f"output.file={tmp_path / 'x.h5'}"])
    assert proc.returncode == 2, proc.stderr[-300:]
    line, = proc.stderr.strip().splitlines()
    assert line.startswith(f"error: {path}: time.end: expected a number, got a list [[[[[[[[[[1, 1")
    assert line.endswith(f"… ({repr_length()} characters)") and len(line) < 400, line[:600]
    assert time.perf_counter() - t0 < 30
    assert not (tmp_path / "x.h5").exists()


def test_long_and_recursive_values_are_clipped():
    from solver.scene.schema import shown
    assert shown("x" * 1000) == "'" + "x" * 199 + "… (1002 characters)"
    loop = [1]
    loop.append(loop)
    assert shown(loop) == repr(loop) == "[1, [...]]"
    assert shown({"a": (1,), "b": [2.5]}) == repr({"a": (1,), "b": [2.5]})
    with pytest.raises(SceneError) as e:
        parsed(dict(network(1.0, 1e-3), name="n" * 10**6))
    assert len(str(e.value)) < 400 and "(1000002 characters)" in str(e.value)
    with pytest.raises(SceneError) as e:                  # a megabyte key
        parsed(dict(network(1.0, 1e-3), **{"k" * 10**6: 1}))
    assert len(str(e.value)) < 800 and "(1000002 characters)" in str(e.value)


# --- 7. nothing to step; absurdly thin shells -----------------------------------

def test_partition_with_every_dof_held_is_refused(tmp_path):
    line = refused("configs/wave_bar_fem.yaml", ["model.fixed=[solid]"], tmp_path)
    assert "partitions[0]: partition 'fem' has no free DOF: every DOF of its" in line, line
    line = refused("configs/plate_shell.yaml", [
        "model.constraints=[{group: plate, dofs: [ux, uy, uz, rx, ry, rz]}]",
        "model.mesh_parameters.n=4"], tmp_path)
    assert "partition 'plate' has no free DOF" in line, line


def test_one_free_dof_is_enough(tmp_path):
    from conftest import built
    raw = raw_scene("plate_shell")
    raw["model"]["mesh_parameters"] = {"n": 4}
    raw["model"]["constraints"] = [{"group": "plate", "dofs": ["ux", "uy", "rx", "ry", "rz"]}]
    asm = built(raw, tmp_path)
    assert int((~asm.model.fixed).sum()) == asm.model.n_nodes       # uz of every node
    asm.destroy()


@pytest.mark.parametrize("thickness", ["1e-200", "1e-9"])
def test_shell_thinner_than_a_millionth_of_its_elements_is_refused(thickness, tmp_path):
    line = refused("configs/plate_shell.yaml", [f"model.material.thickness={thickness}"],
                   tmp_path)
    assert f"model.material.thickness: {float(thickness):g} m is too thin for shell group " \
           "'plate': a wall must be thicker than 1e-06 x its smallest element edge" in line, line


def test_partition_that_owns_no_node_is_refused(tmp_path):
    """A group whose nodes all went to an earlier partition (it used to fail in
    PETSc set-up with an IndexError)."""
    line = refused("configs/wave_bar_fem.yaml", [
        "partitions=[{name: f, method: fem, group: solid, integrator: explicit, beta: 0.0, "
        "ratio: 1}, {name: c, method: fem, group: solid, integrator: implicit, ratio: 2}]",
        "coupling.scheme=staggered", "time.end=4e-6"], tmp_path)
    assert line.endswith("partitions[1]: partition 'c' owns no node (the nodes of group 'solid' "
                         "that the body's cells use all belong to earlier partitions)"), line
