"""A thickness per group of a shell body (model.sections, docs/shells.md):
a stepped cantilever against beam theory on triangles and quadrilaterals,
the stable step of the thinner wall, the fingerprint, and the refusals."""
import numpy as np
import pytest

from conftest import refused, run_scene, write_scene

GEO = """n = 20;
Point(1) = {0, 0, 0}; Point(2) = {0.5, 0, 0}; Point(3) = {1, 0, 0};
Point(4) = {1, 0.1, 0}; Point(5) = {0.5, 0.1, 0}; Point(6) = {0, 0.1, 0};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 5}; Line(5) = {5, 6};
Line(6) = {6, 1}; Line(7) = {2, 5};
Curve Loop(1) = {1, 7, 5, 6}; Plane Surface(1) = {1};
Curve Loop(2) = {2, 3, 4, -7}; Plane Surface(2) = {2};
Transfinite Curve{1, 2, 4, 5} = n / 2 + 1; Transfinite Curve{3, 6, 7} = 3;
Transfinite Surface{1}; Transfinite Surface{2};
If (quads) Recombine Surface{1, 2}; EndIf
Physical Surface("strip") = {1, 2};
Physical Surface("root") = {1};
Physical Surface("tip") = {2};
Physical Surface("both") = {1, 2};
Physical Curve("clamp") = {6};
Physical Curve("end") = {3};
"""
E, T1, T2 = 2.0e11, 0.01, 0.005


def stepped(tmp_path, quads=0, sections=({"group": "tip", "thickness": T2},), **over):
    """A 1 m x 0.1 m strip clamped at x = 0, 10 mm thick on the root half and
    (sections) 5 mm on the tip half, a 1 N tip force across it."""
    geo = tmp_path / "step.geo"
    geo.write_text(GEO)
    raw = {"name": "stepped", "time": {"end": 1.0}, "analysis": "static",
           "model": {"kind": "continuum", "mesh": str(geo), "mesh_parameters": {"quads": quads},
                     "material": {"E": E, "nu": 0.0, "rho": 7800.0, "kind": "shell",
                                  "thickness": T1},
                     "body": "strip", "sections": list(sections), "fixed": ["clamp"]},
           "loads": [{"group": "end", "kind": "rectangular", "amplitude": 10.0, "duration": 2.0,
                      "direction": [0.0, 0.0, 1.0]}],
           "probes": [{"name": "tip", "at": [1.0, 0.05, 0.0], "component": 2}],
           "output": {"file": str(tmp_path / "s.h5")}}
    raw.update(over)
    return raw


@pytest.mark.parametrize("quads", [0, 1])
def test_a_stepped_cantilever_follows_beam_theory(tmp_path, quads):
    """Tip deflection P L^3 / (3 E) ((7/8) / I_root + (1/8) / I_tip) within
    0.2 % (DKT triangles: 1.0001; MITC4: 0.9985); without the section it is
    the uniform strip's, 2.3x stiffer."""
    b, P = 0.1, 1.0
    I1, I2 = b * T1 ** 3 / 12, b * T2 ** 3 / 12
    exact = P / (3 * E) * (7 / 8 / I1 + 1 / 8 / I2)
    w = run_scene(stepped(tmp_path, quads), tmp_path).probes["tip"]["displacement"][0]
    assert w / exact == pytest.approx(1.0, abs=2e-3)
    uniform = run_scene(stepped(tmp_path, quads, sections=()), tmp_path)
    assert uniform.probes["tip"]["displacement"][0] == pytest.approx(P / (3 * E * I1), rel=2e-3)


def test_the_thinner_wall_sets_the_step(tmp_path):
    """Dynamic, physical rotary inertia: the guard's critical step of the
    stepped strip is the 5 mm strip's (the thinner wall's rotations set it),
    not the 10 mm one's."""
    crit = {}
    for name, sections, t in (("stepped", ({"group": "tip", "thickness": T2},), T1),
                              ("thin", (), T2), ("thick", (), T1)):
        raw = stepped(tmp_path, 0, sections, analysis="dynamic",
                      time={"end": 1e-8, "dt": 1e-9},
                      partitions=[{"name": "all", "method": "fem", "group": "strip",
                                   "integrator": "explicit", "ratio": 1}])
        raw["model"]["material"]["thickness"] = t
        raw["output"] = {"file": str(tmp_path / f"{name}.h5")}
        crit[name] = run_scene(raw, tmp_path).partitions["all"]["critical_step"]
    assert crit["stepped"] == pytest.approx(crit["thin"], rel=0.02), crit
    assert crit["thick"] > 1.5 * crit["thin"], crit


def test_a_checkpoint_knows_its_sections(tmp_path):
    from solver.driver.state import fingerprint
    from solver.model import binding
    with_none = fingerprint(binding.from_dict(stepped(tmp_path, sections=())))
    raw = stepped(tmp_path, sections=())
    del raw["model"]["sections"]
    assert fingerprint(binding.from_dict(raw)) == with_none
    assert fingerprint(binding.from_dict(stepped(tmp_path))) != with_none


@pytest.mark.parametrize("sections, message", [
    ([{"group": "nowhere", "thickness": 0.005}],
     "model.sections[0].group: mesh has no physical group 'nowhere'"),
    ([{"group": "tip", "thickness": 0.0}], "model.sections[0].thickness: "),
    ([{"group": "tip"}], "model.sections[0].thickness"),
    ([{"group": "tip", "thickness": 0.005}, {"group": "both", "thickness": 0.002}],
     "model.sections[1].group: gmsh element"),
    ([{"group": "clamp", "thickness": 0.005}],
     "model.sections[0].group: group 'clamp' has line2 cells; shell elements are"),
])
def test_bad_sections_are_refused(tmp_path, sections, message):
    path = write_scene(tmp_path / "bad.yaml", stepped(tmp_path, sections=sections))
    line = refused(str(path), [], tmp_path)
    assert message in line, line


def test_a_section_outside_the_body_is_refused(tmp_path):
    raw = stepped(tmp_path)
    raw["model"]["body"] = "root"
    raw["loads"], raw["probes"] = [], []
    line = refused(str(write_scene(tmp_path / "out.yaml", raw)), [], tmp_path)
    assert "model.sections[0].group: group 'tip' has 40 of its 40 cells outside the shell " \
        "body 'root'" in line, line


def test_sections_belong_to_shell_bodies(tmp_path):
    line = refused("configs/wave_bar_fem.yaml",
                   ['model.sections=[{group: solid, thickness: 0.01}]'], tmp_path)
    assert "model.sections: sections give a shell body's groups their thickness" in line, line


@pytest.mark.parametrize("quads", [0, 1])
def test_top_middle_and_bottom_stresses(tmp_path, quads):
    """The uniform 10 mm strip under its tip force: in each cell of the root
    half the top and bottom stresses are the bending stress -+ 6 M / t^2,
    M = P (L - x_c) / b at its centre (von Mises of the uniaxial state,
    within 3 %: the cells' centroids sample a linear moment), the middle
    surface carries none, and von_mises is the larger face's."""
    from meshio.xdmf import TimeSeriesReader
    raw = stepped(tmp_path, quads, sections=())
    raw["output"]["fields"] = {"every": 1}
    run_scene(raw, tmp_path)
    reader = TimeSeriesReader(str(tmp_path / "stepped_fields.xdmf"))
    points, cells = reader.read_points_cells()
    _, _, cd = reader.read_data(0)

    def mises(s):
        return np.sqrt(s[:, 0] ** 2 - s[:, 0] * s[:, 1] + s[:, 1] ** 2 + 3 * s[:, 2] ** 2)
    for k, block in enumerate(cells):
        xc = points[block.data].mean(axis=1)[:, 0]
        root = xc < 0.5
        M = 1.0 * (1.0 - xc[root]) / 0.1
        top, mid, bottom = (cd[f"stress_{s}"][k][root] for s in ("top", "middle", "bottom"))
        assert np.abs(mises(top) / (6 * M / T1 ** 2) - 1).max() < 0.03
        assert np.allclose(top, -bottom, rtol=1e-9, atol=1e-9 * np.abs(top).max())
        assert np.abs(mid).max() < 1e-6 * np.abs(top).max()
        assert np.allclose(cd["von_mises"][k][root], mises(top), rtol=1e-12)
