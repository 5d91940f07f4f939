"""Pressure loads (loads[].pressure, solver/model/pressure.py): into the body
on the faces of tetrahedra and hexahedra and on the edges of a plane body
(uniaxial compression, exact), against the node-order normal of shell cells
(an open cylinder's uniform expansion p R^2 / (E t)), and the refusals."""
import h5py
import numpy as np
import pytest

from conftest import raw_scene, refused, run_scene, write_scene

BOX = """SetFactory("OpenCASCADE");
If (!Exists(hex)) hex = 0; EndIf
Box(1) = {0, 0, 0, 0.2, 0.1, 0.1};
Mesh.CharacteristicLengthMax = 0.04;
If (hex)
  Transfinite Curve{:} = 4; Transfinite Surface{:}; Recombine Surface{:}; Transfinite Volume{1};
EndIf
Physical Volume("solid") = {1};
Physical Surface("x0") = Surface In BoundingBox {-1e-6, -1, -1, 1e-6, 1, 1};
Physical Surface("x1") = Surface In BoundingBox {0.2 - 1e-6, -1, -1, 0.2 + 1e-6, 1, 1};
Physical Surface("y0") = Surface In BoundingBox {-1, -1e-6, -1, 1, 1e-6, 1};
Physical Surface("z0") = Surface In BoundingBox {-1, -1, -1e-6, 1, 1, 1e-6};
Physical Curve("edge") = Curve In BoundingBox {0.2 - 1e-6, -1, -1e-6, 0.2 + 1e-6, 1, 1e-6};
"""
CYLINDER = """If (!Exists(quads)) quads = 1; EndIf
n = 12;
Point(1) = {0, 0, 0}; Point(2) = {1, 0, 0}; Point(3) = {0, 1, 0};
Circle(1) = {2, 1, 3};
Transfinite Curve{1} = n + 1;
If (quads)
  s[] = Extrude {0, 0, 1} { Curve{1}; Layers{n}; Recombine; };
Else
  s[] = Extrude {0, 0, 1} { Curve{1}; Layers{n}; };
EndIf
Physical Surface("wall") = {s[1]};
Physical Curve("xz") = Curve In BoundingBox {0.5, -1e-6, -1e-6, 1.5, 1e-6, 2};
Physical Curve("yz") = Curve In BoundingBox {-1e-6, 0.5, -1e-6, 1e-6, 1.5, 2};
Physical Curve("bottom") = {1};
"""
E, NU, P = 2.0e11, 0.3, 1.0e6


def box(tmp_path, hex, **load):
    geo = tmp_path / "box.geo"
    geo.write_text(BOX)
    return {"name": "box", "time": {"end": 1.0}, "analysis": "static",
            "model": {"kind": "continuum", "mesh": str(geo), "mesh_parameters": {"hex": hex},
                      "material": {"E": E, "nu": NU, "rho": 7800.0, "kind": "solid"},
                      "body": "solid",
                      "constraints": [{"group": "x0", "dofs": ["ux"]},
                                      {"group": "y0", "dofs": ["uy"]},
                                      {"group": "z0", "dofs": ["uz"]}]},
            "loads": [{"group": "x1", "pressure": True, "kind": "rectangular", "amplitude": P,
                       "duration": 2.0, **load}],
            "probes": [{"name": "end", "at": [0.2, 0.1, 0.1], "component": 0},
                       {"name": "side", "at": [0.2, 0.1, 0.1], "component": 1}],
            "output": {"file": str(tmp_path / "box.h5")}}


@pytest.mark.parametrize("hex", [0, 1])
def test_pressure_on_a_solid_face_compresses_it(tmp_path, hex):
    """A 0.2 x 0.1 x 0.1 block on rollers, pressure p on its face x = 0.2:
    uniaxial compression, the end moving -p L / E and the side +nu p W / E,
    exactly (1e-12) on tetrahedra and hexahedra."""
    res = run_scene(box(tmp_path, hex), tmp_path)
    assert res.probes["end"]["displacement"][0] / (-P * 0.2 / E) == pytest.approx(1, abs=1e-12)
    assert res.probes["side"]["displacement"][0] / (NU * P * 0.1 / E) == pytest.approx(1, abs=1e-12)


def test_pressure_on_a_plane_edge_is_the_inward_traction(tmp_path):
    """configs/wave_bar_fem.yaml's strip statically: a pressure on its left
    edge gives the state the traction along the edge's inward normal [1, 0]
    gives (1e-12)."""
    out = []
    for load in ({"pressure": True}, {"direction": [1.0, 0.0]}):
        raw = raw_scene("wave_bar_fem")
        raw.update(analysis="static", time={"end": 1.0}, reference="none",
                   loads=[{"group": "left", "kind": "rectangular", "amplitude": 1.0e4,
                           "duration": 2.0, **load}],
                   probes=[{"name": "tip", "at": [0.0, 0.0012], "component": 0}])
        del raw["partitions"]
        raw["output"] = {"file": str(tmp_path / f"{len(out)}.h5")}
        out.append(run_scene(raw, tmp_path).probes["tip"]["displacement"][0])
    assert out[0] > 0 and out[0] == pytest.approx(out[1], rel=1e-12)


@pytest.mark.parametrize("quads, worst", [(1, 0.003), (0, None)])
def test_an_open_cylinder_under_pressure_expands_uniformly(tmp_path, quads, worst):
    """A quarter of an open cylinder (R 1, L 1, t 10 mm, symmetry edges) of 12 x
    12 shell cells whose node-order normal points out, pressure p: every node
    moves radially by -p R^2 / (E t) (inwards: the pressure pushes against the
    normal), on MITC4 quadrilaterals within 0.3 % at every node; on the
    triangles split from them the median within 0.5 % (their boundary nodes'
    uneven load shares bend the free edge; the interior's error falls 4x per
    halving, tests of the course)."""
    geo = tmp_path / "cyl.geo"
    geo.write_text(CYLINDER)
    raw = {"name": "cyl", "time": {"end": 1.0}, "analysis": "static",
           "model": {"kind": "continuum", "mesh": str(geo), "mesh_parameters": {"quads": quads},
                     "material": {"E": E, "nu": NU, "rho": 7800.0, "kind": "shell",
                                  "thickness": 0.01},
                     "body": "wall",
                     "constraints": [{"group": "xz", "dofs": ["uy", "rx", "rz"]},
                                     {"group": "yz", "dofs": ["ux", "ry", "rz"]},
                                     {"group": "bottom", "dofs": ["uz", "rx", "ry"]}]},
           "loads": [{"group": "wall", "pressure": True, "kind": "rectangular",
                      "amplitude": 1.0e5, "duration": 2.0}],
           "output": {"file": str(tmp_path / "cyl.h5"), "fields": {"every": 1}}}
    run_scene(raw, tmp_path)
    with h5py.File(tmp_path / "cyl_fields.h5") as f:
        pts, u = f["data0"][()], f["data2"][()]
    r = np.hypot(pts[:, 0], pts[:, 1])
    on = r > 0.5                                    # (the circle's centre point is no node of it)
    radial = np.einsum("nx,nx->n", u[on, :2], pts[on, :2]) / r[on] / (-1.0e5 / (E * 0.01))
    if worst is not None:
        assert np.abs(radial - 1).max() < worst, radial
    else:
        assert abs(np.median(radial) - 1) < 0.005, np.median(radial)


@pytest.mark.parametrize("load, message", [
    ({"group": "edge"}, "loads[0].group: group 'edge' has line2 cells: a pressure acts on faces"),
    ({"group": "x1", "direction": [1.0, 0.0, 0.0]},
     "loads[0].direction: a pressure acts along each facet's normal"),
    ({"group": None, "at": [0.2, 0.1, 0.1]}, "loads[0].pressure: is for group loads"),
])
def test_bad_pressures_are_refused(tmp_path, load, message):
    raw = box(tmp_path, 1, **load)
    if raw["loads"][0]["group"] is None:
        del raw["loads"][0]["group"]
    line = refused(str(write_scene(tmp_path / "bad.yaml", raw)), [], tmp_path)
    assert message in line, line


def test_a_checkpoint_knows_its_pressure(tmp_path):
    """The fingerprint leaves pressure: false out (checkpoints written before
    the key existed still restart) and tells a pressure from a traction."""
    from solver.driver.state import fingerprint
    from solver.model import binding
    traction = box(tmp_path, 1, direction=[-1.0, 0.0, 0.0])
    traction["loads"][0]["pressure"] = False
    older = box(tmp_path, 1, direction=[-1.0, 0.0, 0.0])
    del older["loads"][0]["pressure"]
    prints = [fingerprint(binding.from_dict(r)) for r in (traction, older, box(tmp_path, 1))]
    assert prints[0] == prints[1] != prints[2]


def test_a_pressure_inside_or_off_the_body_is_refused(tmp_path):
    """A surface embedded in the block (on two of its cells), naming the
    element, and, on a shell model, a pressure or a traction on a patch that
    is not the body's, naming the nodes off it."""
    geo = tmp_path / "crack.geo"
    geo.write_text("""SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 0.2, 0.1, 0.1};
Rectangle(10) = {0.1, 0.02, 0.02, 0.06, 0.06}; Rotate{{0, 1, 0}, {0.1, 0.02, 0.02}, -Pi/2}{Surface{10};}
BooleanFragments{ Volume{1}; Delete; }{ Surface{10}; Delete; }
Mesh.CharacteristicLengthMax = 0.04;
Physical Volume("solid") = {1};
Physical Surface("x0") = Surface In BoundingBox {-1e-6, -1, -1, 1e-6, 1, 1};
Physical Surface("y0") = Surface In BoundingBox {-1, -1e-6, -1, 1, 1e-6, 1};
Physical Surface("z0") = Surface In BoundingBox {-1, -1, -1e-6, 1, 1, 1e-6};
Physical Surface("x1") = Surface In BoundingBox {0.1 - 1e-6, 0.01, 0.01, 0.1 + 1e-6, 0.09, 0.09};
""")
    raw = box(tmp_path, 0)
    raw["model"].update(mesh=str(geo), mesh_parameters={})
    line = refused(str(write_scene(tmp_path / "crack.yaml", raw)), [], tmp_path)
    assert "of group 'x1' lies inside the body (on two of its cells)" in line, line
    from test_shell_sections import stepped
    raw = stepped(tmp_path, 0, sections=())
    raw["model"]["body"] = "root"
    raw["probes"] = []
    for load in ({"pressure": True}, {"direction": [0.0, 0.0, 1.0]}):     # a traction too
        raw["loads"] = [{"group": "tip", "kind": "rectangular", "amplitude": 1.0,
                         "duration": 2.0, **load}]
        line = refused(str(write_scene(tmp_path / "off.yaml", raw)), [], tmp_path)
        assert "loads[0].group: group 'tip': 30 of its 33 nodes are on no cell of the body" \
            in line, line
