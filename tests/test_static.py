"""analysis: static: K u = f once, against closed forms (a hanging bar, a
simply supported plate of shells), 1 vs 2 ranks, one output sample, refusals."""
import h5py
import numpy as np
import pytest

from conftest import raw_scene, run_cli, run_scene, write_scene

E, RHO, L = 70e9, 2700.0, 0.32          # configs/wave_bar_fem.yaml's strip


def hanging(g=1000.0, **over):
    """The 0.32 m strip fixed at x = L, gravity g along -x, no partitions, no dt."""
    raw = raw_scene("wave_bar_fem")
    raw.update(name="hanging", analysis="static", time={"end": 1.0}, loads=[],
               gravity=[-g, 0.0],
               probes=[{"name": "tip", "at": [0.0, 0.0012]}, {"name": "mid", "at": [0.16, 0.0012]}])
    del raw["partitions"], raw["reference"]
    raw.update(over)
    return raw


def test_a_hanging_bar_takes_its_static_stretch(tmp_path):
    """u(x) = -rho g (L^2 - x^2) / (2 E) (1D; the clamped end's Poisson
    constraint moves it by 0.03 %), one sample at time.end, strain energy =
    external work = 1/2 f . u, at rest."""
    g = 1000.0
    res = run_scene(hanging(g, output={"fields": {"every": 1}}), tmp_path)
    for name, x in (("tip", 0.0), ("mid", 0.16)):
        pr = res.probes[name]
        assert pr["t"].tolist() == [1.0] and pr["velocity"].tolist() == [0.0]
        exact = -RHO * g * (L ** 2 - x ** 2) / (2 * E)
        assert abs(pr["displacement"][0] / exact - 1) < 1e-3, (name, pr["displacement"], exact)
    en = res.energy
    assert en["t"].tolist() == [1.0] and en["kinetic"].tolist() == [0.0]
    assert abs(en["strain"][0] / en["external_work"][0] - 1) < 1e-10
    # the strain energy of the 1D solution: integral of (rho g x)^2 / (2 E) A dx
    area = 2.4e-3 * 3.2e-4
    assert abs(en["strain"][0] / ((RHO * g) ** 2 * L ** 3 / (6 * E) * area) - 1) < 2e-3
    assert res.attrs["analysis"] == "static" and res.status == "completed"
    import meshio                                        # the fields hold the static state alone
    with meshio.xdmf.TimeSeriesReader(str(tmp_path / "hanging_fields.xdmf")) as r:
        r.read_points_cells()
        assert r.num_steps == 1
        t, point_data, _ = r.read_data(0)
    assert t == 1.0
    assert point_data["displacement"][:, 0].min() == res.probes["tip"]["displacement"][0]


def test_loads_at_time_end_and_a_given_partition(tmp_path):
    """A traction ramped by a table is taken at time.end; one given fem
    partition (its name the KSP's log, its group the body) gives the same."""
    q, t_end = 1.0e4, 2.0
    raw = hanging(0.0, gravity=None, time={"end": t_end},
                  loads=[{"group": "left", "kind": "tabulated", "table": [[0, 0], [4, 2 * q]],
                          "direction": [-1.0, 0.0]}],
                  partitions=[{"name": "bar", "method": "fem", "group": "solid",
                               "integrator": "explicit", "ratio": 1}])
    res = run_scene(raw, tmp_path)
    sigma = q / 3.2e-4                                   # the table's value at t = 2: q
    tip = res.probes["tip"]["displacement"][0]
    assert abs(tip / (-sigma * L / E) - 1) < 2e-3, tip    # (the clamp's Poisson constraint)
    assert "bar" in res.partitions


def test_a_simply_supported_plate_of_shells_under_a_central_load(tmp_path):
    """configs/plate_shell.yaml (1 m square, 10 mm steel, edges held in
    translation, 16 x 16 x 2 DKT facets) under 1 kN at the centre: Kirchhoff's
    w = 0.0116 P a^2 / D (Timoshenko & Woinowsky-Krieger, table 23) within 1 %."""
    raw = raw_scene("plate_shell")
    raw.update(analysis="static", time={"end": 1.0},
               loads=[{"at": [0.5, 0.5, 0.0], "component": 2, "kind": "rectangular",
                       "amplitude": 1000.0, "duration": 2.0}])
    w = run_scene(raw, tmp_path).probes["centre"]["displacement"][0]
    D = 210e9 * 0.01 ** 3 / (12 * (1 - 0.3 ** 2))
    assert abs(w / (0.0116 * 1000.0 / D) - 1) < 0.01, w


def test_one_and_two_ranks_agree(tmp_path):
    """LU on one rank, CG + GAMG (rigid-body near-null space) on two: to 1e-8.
    (An axial case: a transverse tip load on this 133:1 strip is conditioned so
    that LU's own u.Ku and f.u differ by 6e-8.)"""
    raw = hanging(1000.0, loads=[{"group": "left", "kind": "rectangular", "amplitude": 50.0,
                                  "duration": 2.0, "direction": [1.0, 0.0]}])
    out = []
    for n in (None, 2):
        raw["output"] = {"file": str(tmp_path / f"r{n}.h5")}
        proc = run_cli([write_scene(tmp_path / f"s{n}.yaml", raw)], n=n, timeout=300)
        assert proc.returncode == 0, proc.stderr
        assert ("preonly + PC lu" if n is None else "cg + PC gamg") in proc.stdout
        with h5py.File(tmp_path / f"r{n}.h5") as f:
            out.append({k: f[f"probes/{p}/displacement"][()] for p in ("tip", "mid")
                        for k in [p]} | {"strain": f["energy/strain"][()]})
    for key in out[0]:
        assert np.abs(out[0][key] - out[1][key]).max() <= 1e-8 * np.abs(out[0][key]).max(), key


@pytest.mark.parametrize("over, message", [
    ({"model": "free"}, "analysis: static: the model is free to move (3 rigid-body mode(s) no "
     "fixed DOF holds: translation in x; translation in y; rotation about z)"),
    ({"model": "x only"}, "analysis: static: the model is free to move (1 rigid-body mode(s) "
     "no fixed DOF holds: translation in y)"),
    ({"partitions": [{"name": "a", "method": "fem", "group": "solid", "integrator": "explicit",
                      "ratio": 1}] * 2},
     "partitions: analysis static solves the whole model at once: give one fem partition or "
     "none (2 given)"),
    ({"initial": {"motion": [{"velocity": [1, 0]}]}},
     "initial.motion: not with analysis static: a static solve starts from nothing"),
    ({"output": {"checkpoint": {"every": 1}}},
     "output.checkpoint: not with analysis static: a static solve has nothing to restart"),
    ({"time": {"end": 1.0, "dt": "auto"}}, "time.dt: auto makes levels for a dynamic run"),
])
def test_static_refusals(over, message, tmp_path):
    raw = hanging()
    if over.get("model") == "free":
        raw["model"] = {**raw["model"], "fixed": []}
        del over["model"]
    elif over.get("model") == "x only":
        raw["model"] = {**raw["model"], "fixed": [],
                        "constraints": [{"group": "right", "dofs": ["ux"]}]}
        del over["model"]
    raw.update(over)
    raw["output"] = {**raw.get("output", {}), "file": str(tmp_path / "bad.h5")}
    proc = run_cli([write_scene(tmp_path / "bad.yaml", raw)])
    assert proc.returncode == 2, proc.stderr
    assert message in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr and not (tmp_path / "bad.h5").exists()


def test_static_is_for_continua_and_dynamics_needs_a_step(tmp_path):
    net = raw_scene("six_dof")
    net["analysis"] = "static"
    proc = run_cli([write_scene(tmp_path / "net.yaml", net)])
    assert proc.returncode == 2 and "analysis: static is for continuum models" in proc.stderr
    raw = raw_scene("wave_bar_fem")
    raw["time"] = {"end": 1e-5}
    proc = run_cli([write_scene(tmp_path / "dyn.yaml", raw)])
    assert proc.returncode == 2 and "time.dt: required: the base step" in proc.stderr, proc.stderr


def preloaded_bar(tmp_path, split=False):
    """The hanging strip as a dynamic run from its preload (or tests/test_continuum.py's
    split bar, fem partitions west (ratio 2) and east, hanging from its right end)."""
    raw = hanging(1000.0)
    del raw["analysis"]
    raw.update(preload="static", time={"end": 1.0e-5, "dt": 1.0e-8},
               partitions=[{"name": "fem", "method": "fem", "group": "solid",
                            "integrator": "explicit", "ratio": 1}])
    if split:
        raw["model"]["mesh"] = raw["model"]["mesh"].replace("wave_bar.geo", "bar_split.geo")
        raw["partitions"] = [
            {"name": "west", "method": "fem", "group": "west", "integrator": "explicit", "ratio": 2},
            {"name": "east", "method": "fem", "group": "east", "integrator": "explicit", "ratio": 1}]
        raw["probes"] = [{"name": "tip", "at": [0.0, 0.0008]}, {"name": "mid", "at": [0.016, 0.0008]}]
    return raw


def test_a_preloaded_run_starts_and_stays_in_equilibrium(tmp_path):
    """preload: static starts the dynamic run from the static state under
    gravity: the strip's tip stays at the static solve's value (to 1e-12) at
    rest, where it would otherwise swing to twice its sag."""
    raw = preloaded_bar(tmp_path)
    res = run_scene(raw, tmp_path)
    static = run_scene(hanging(1000.0), tmp_path).probes["tip"]["displacement"][0]
    u, v = res.probes["tip"]["displacement"], res.probes["tip"]["velocity"]
    assert abs(u[0] / static - 1) < 1e-12
    assert np.abs(u / static - 1).max() < 1e-10
    assert np.abs(v).max() < 1e-10 * abs(static) / 1e-5        # (against a sag over the run)
    en = res.energy
    assert abs(en["strain"][0] / 4.36592e-07 - 1) < 1e-5         # the static strain energy
    assert en["kinetic"].max() < 1e-12 * en["strain"][0]


def test_a_preloaded_split_bar_on_one_and_two_ranks(tmp_path):
    """Two fem partitions (ratios 2 and 1) coupled by the overlap exchange
    start from the whole model's static state and keep it, on 1 and 2 ranks."""
    raw = preloaded_bar(tmp_path, split=True)
    out = []
    for n in (None, 2):
        raw["output"] = {"file": str(tmp_path / f"p{n}.h5")}
        proc = run_cli([write_scene(tmp_path / f"p{n}.yaml", raw)], n=n, timeout=300)
        assert proc.returncode == 0, proc.stderr
        assert "preload: the run starts from the static state at t = 0" in proc.stdout
        with h5py.File(tmp_path / f"p{n}.h5") as f:
            out.append({p: f[f"probes/{p}/displacement"][()] for p in ("tip", "mid")})
    static = -RHO * 1000.0 * 0.032 ** 2 / (2 * E)                # 1D, L = 32 mm
    for run in out:
        tip = run["tip"]
        assert abs(tip[0] / static - 1) < 0.01, tip[0]
        assert np.abs(tip / tip[0] - 1).max() < 1e-10
    for p in ("tip", "mid"):
        assert np.abs(out[0][p] - out[1][p]).max() <= 1e-8 * np.abs(out[0][p]).max(), p


@pytest.mark.parametrize("edit, message", [
    (lambda r: r.update(analysis="static"),
     "preload: is for dynamic runs (analysis static is the static state itself)"),
    (lambda r: r.update(initial={"motion": [{"displacement": [1e-6, 0]}]}),
     "initial.motion[0].displacement: not with preload static"),
    (lambda r: r["model"].update(fixed=[]),
     "preload: static: the model is free to move (3 rigid-body mode(s)"),
])
def test_preload_refusals(edit, message, tmp_path):
    raw = preloaded_bar(tmp_path)
    edit(raw)
    raw["output"] = {"file": str(tmp_path / "bad.h5")}
    proc = run_cli([write_scene(tmp_path / "bad.yaml", raw)])
    assert proc.returncode == 2, proc.stderr
    assert message in proc.stderr, proc.stderr
    assert not (tmp_path / "bad.h5").exists()


def test_preload_needs_a_lattice_free_continuum(tmp_path):
    for name, message in (("bar3d", "preload: static solves the FE model: a lattice's bonds"),
                          ("six_dof", "preload: static is for continuum models")):
        raw = raw_scene(name)
        raw["preload"] = "static"
        proc = run_cli([write_scene(tmp_path / "s.yaml", raw)])
        assert proc.returncode == 2 and message in proc.stderr, proc.stderr
