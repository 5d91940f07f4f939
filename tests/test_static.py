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
