"""Meshes that the element kernels must not take on trust: cells listed twice
(MSH 2 writes an element once per physical group), face tractions on
non-parallelogram faces, non-convex and clockwise cells, non-finite nodes,
element types the kernels lack; network files that are not HDF5; load keys
that a load kind would silently ignore."""
import numpy as np
import pytest

from conftest import ROOT, raw_scene, refused, run_cli, write_scene
from solver.errors import SceneError
from solver.model.elements import Elastic
from solver.model.mesh import read
from solver.model.cell_blocks import group_matrices

STEEL = Elastic(200e9, 0.3, 7800.0, "plane_strain")


def msh22(path, nodes, elements, names):
    """Write an ASCII MSH 2.2 file: ``nodes`` [(x, y, z)], ``elements``
    [(gmsh type, physical tag, entity tag, node numbers from 1)], ``names``
    [(dim, physical tag, name)]."""
    lines = ["$MeshFormat", "2.2 0 8", "$EndMeshFormat", "$PhysicalNames", str(len(names))]
    lines += [f'{d} {t} "{n}"' for d, t, n in names]
    lines += ["$EndPhysicalNames", "$Nodes", str(len(nodes))]
    lines += [f"{i + 1} {' '.join(str(c) for c in p)}" for i, p in enumerate(nodes)]
    lines += ["$EndNodes", "$Elements", str(len(elements))]
    lines += [f"{i + 1} {t} 2 {phys} {ent} {' '.join(map(str, conn))}"
              for i, (t, phys, ent, conn) in enumerate(elements)]
    lines += ["$EndElements"]
    path.write_text("\n".join(lines) + "\n")
    return str(path)


def grid(nx=3, ny=2):
    """Nodes and counter-clockwise quad4 cells (node numbers from 1) of a
    unit-spaced nx x ny grid, with its left edge (line2)."""
    nodes = [(float(i), float(j), 0.0) for j in range(ny + 1) for i in range(nx + 1)]
    n = lambda i, j: j * (nx + 1) + i + 1                                    # noqa: E731
    quads = [(n(i, j), n(i + 1, j), n(i + 1, j + 1), n(i, j + 1))
             for j in range(ny) for i in range(nx)]
    left = [(n(0, j), n(0, j + 1)) for j in range(ny)]
    return nodes, quads, left


def total_mass(mesh, group="solid"):
    return sum(me.sum() for _, _, _, me in group_matrices(mesh, group, STEEL, "model.body"))


# -- 1. cells listed twice ---------------------------------------------------------------

def _gmsh_rectangle(path, groups, version=2.2, quads=True):
    """A 3 x 1 rectangle meshed by gmsh's API, its surface in physical groups
    ``groups`` (each a name), written as MSH ``version``."""
    import gmsh
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("r")
        s = gmsh.model.occ.addRectangle(0, 0, 0, 3.0, 1.0)
        gmsh.model.occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.4)
        if quads:
            gmsh.option.setNumber("Mesh.RecombineAll", 1)
        for name in groups:
            gmsh.model.setPhysicalName(2, gmsh.model.addPhysicalGroup(2, [s]), name)
        left = [t for d, t in gmsh.model.getEntities(1)
                if abs(gmsh.model.occ.getCenterOfMass(1, t)[0]) < 1e-12]
        gmsh.model.setPhysicalName(1, gmsh.model.addPhysicalGroup(1, left), "left")
        gmsh.model.mesh.generate(2)
        gmsh.option.setNumber("Mesh.MshFileVersion", version)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return str(path)


@pytest.mark.parametrize("version", [2.2, 4.1])
@pytest.mark.parametrize("quads", [True, False])
def test_surface_in_two_physical_groups_has_the_single_groups_mass(tmp_path, version, quads):
    one = read(_gmsh_rectangle(tmp_path / "one.msh", ["solid"], version, quads))
    two = read(_gmsh_rectangle(tmp_path / "two.msh", ["solid", "also"], version, quads))
    fam = "quad4" if quads else "tri3"
    assert two.group("solid").cells[fam].shape == one.group("solid").cells[fam].shape
    assert total_mass(two) == total_mass(one)
    assert total_mass(one) == pytest.approx(STEEL.rho * 3.0, rel=1e-12)
    assert total_mass(two, "also") == total_mass(one)


def test_cells_listed_twice_are_kept_once_and_noted(tmp_path):
    """Every cell written twice (with its own element number, as some MSH 2
    writers do), once in reversed node order: the mass is the grid's, the log
    says how many were removed."""
    nodes, quads, left = grid()
    once = [(3, 1, 1, q) for q in quads] + [(1, 2, 2, e) for e in left]
    twice = once + [(3, 1, 1, q) for q in quads[:-1]] + [(3, 1, 1, quads[-1][::-1])] + \
        [(1, 2, 2, e[::-1]) for e in left]
    names = [(2, 1, "solid"), (1, 2, "left")]
    single = read(msh22(tmp_path / "once.msh", nodes, once, names))
    double = read(msh22(tmp_path / "twice.msh", nodes, twice, names))
    assert total_mass(double) == total_mass(single) == pytest.approx(STEEL.rho * 6.0, rel=1e-12)
    assert np.array_equal(double.group("solid").cells["quad4"],
                          single.group("solid").cells["quad4"])
    assert double.group("left").cells["line2"].shape == (2, 2)
    assert single.notes == ()
    assert any("removed 6 duplicated quad4 cells" in n and "'solid'" in n for n in double.notes)
    assert any("removed 2 duplicated line2 cells" in n for n in double.notes)


SCENE_2D = """name: t
time: {{end: 2.0e-7, dt: 1.0e-7}}
model:
  kind: continuum
  mesh: {mesh}
  material: {{E: 200.0e9, nu: 0.3, rho: 7800.0, kind: plane_strain}}
  body: solid
partitions:
  - {{name: fem, method: fem, group: solid, integrator: explicit, ratio: 1}}
loads:
  - {{group: left, kind: sine, amplitude: 1.0e3, omega: 1.0e5}}
probes:
  - {{name: a, node: 0}}
output: {{file: {out}, progress: 0}}
"""


def test_run_logs_the_removed_duplicates(tmp_path):
    nodes, quads, left = grid()
    els = [(3, 1, 1, q) for q in quads] * 2 + [(1, 2, 2, e) for e in left]
    mesh = msh22(tmp_path / "twice.msh", nodes, els, [(2, 1, "solid"), (1, 2, "left")])
    scene = tmp_path / "s.yaml"
    scene.write_text(SCENE_2D.format(mesh=mesh, out=tmp_path / "s.h5"))
    proc = run_cli([scene])
    assert proc.returncode == 0, proc.stderr
    assert f"mesh {mesh}: group 'solid': removed 6 duplicated quad4 cells" in proc.stdout


# -- 2. consistent face tractions -----------------------------------------------------------

def _fine_weights(X, n=800):
    """integral of N_a dA over the bilinear quad X [4, space], by the midpoint
    rule on n x n parametric cells (written out here, independent of the
    solver's Gauss rule)."""
    s = (np.arange(n) + 0.5) / n * 2 - 1
    xi, eta = np.meshgrid(s, s, indexing="ij")
    sx, sy = np.array([-1, 1, 1, -1]), np.array([-1, -1, 1, 1])
    N = [(1 + sx[a] * xi) * (1 + sy[a] * eta) / 4 for a in range(4)]
    dxi = sum(np.multiply.outer(sx[a] * (1 + sy[a] * eta) / 4, X[a]) for a in range(4))
    deta = sum(np.multiply.outer(sy[a] * (1 + sx[a] * xi) / 4, X[a]) for a in range(4))
    if X.shape[1] == 3:
        dA = np.linalg.norm(np.cross(dxi, deta), axis=-1)
    else:
        dA = np.abs(dxi[..., 0] * deta[..., 1] - dxi[..., 1] * deta[..., 0])
    return np.array([(N[a] * dA).sum() for a in range(4)]) * (2 / n) ** 2


# a hexahedron whose face x = 0 is a trapezoid: parallel sides 1 and 3 (along z), height 2
HEX = [(0, 0, 0), (2, 0, 0), (2, 2, 0), (0, 2, 0), (0, 0, 3), (2, 0, 2.5), (2, 2, 1.5), (0, 2, 1)]


def test_trapezoid_face_traction_is_the_integral_of_n(tmp_path):
    from solver.model.boundary import facet_forces
    names = [(3, 1, "solid"), (2, 2, "face")]
    face = (1, 4, 8, 5)                               # x = 0: (0,0,0) (0,2,0) (0,2,1) (0,0,3)
    path = msh22(tmp_path / "hex.msh", HEX, [(5, 1, 1, tuple(range(1, 9))),
                                             (3, 2, 2, face)], names)
    mesh = read(path)
    w = facet_forces(mesh, "face", "loads[0].group")
    X = np.array([HEX[i - 1] for i in face], dtype=float)
    exact = _fine_weights(X)
    nodes = [int(np.flatnonzero((mesh.points == x).all(axis=1))[0]) for x in X]   # by place
    assert w[nodes] == pytest.approx(exact, rel=1e-5)
    assert w.sum() == pytest.approx(0.5 * (3 + 1) * 2, rel=1e-12)     # the trapezoid's area
    assert np.ptp(w[nodes]) > 0.3                     # not area/4 per node
    # analytic: parallel sides a (at y = 0) and b (at y = h); the two nodes of side a
    # share integral (1 - y/h) (a + (b - a) y/h) dy = h (2a + b)/6, those of side b the rest
    a, b, h = 3.0, 1.0, 2.0
    assert w[nodes[0]] + w[nodes[3]] == pytest.approx(h * (2 * a + b) / 6, rel=1e-12)
    assert w[nodes[1]] + w[nodes[2]] == pytest.approx(h * (a + 2 * b) / 6, rel=1e-12)


@pytest.mark.parametrize("X", [
    [(0, 0, 0), (4, 0, 0), (3, 2, 0), (0.5, 1.5, 0)],                   # plane, no parallels
    [(0, 0, 0), (2, 0, 0.3), (2.5, 2, -0.2), (0, 1, 0.4)],              # warped
    [(0, 0), (4, 0), (3, 2), (0.5, 1.5)]])                              # a 2D patch
def test_quad_face_weights_match_fine_integration(X):
    from solver.model.boundary import facet_weights
    X = np.array(X, dtype=float)
    w = facet_weights("quad4", X[None])[0]
    exact = _fine_weights(X)
    plane = X.shape[1] == 2 or np.ptp(X[:, 2]) == 0
    assert w == pytest.approx(exact, rel=1e-5 if plane else 5e-5)
    assert np.abs(w - w.mean()).max() > 0.05 * w.mean()


def test_line_and_triangle_weights_are_exact():
    from solver.model.boundary import facet_weights
    assert facet_weights("line2", np.array([[[0.0, 0.0], [3.0, 4.0]]]))[0] == \
        pytest.approx([2.5, 2.5], rel=1e-15)
    tri = np.array([[[0.0, 0, 0], [2, 0, 0], [0, 3, 1]]])
    area = 0.5 * np.linalg.norm(np.cross(tri[0, 1], tri[0, 2]))
    assert facet_weights("tri3", tri)[0] == pytest.approx([area / 3] * 3, rel=1e-15)
    assert facet_weights("tri3", tri[:, :, :2])[0] == pytest.approx([1.0] * 3, rel=1e-15)


# -- 3. non-convex and clockwise cells --------------------------------------------------------

def test_dart_quad_is_refused_naming_the_element_and_group(tmp_path):
    nodes, quads, left = grid(2, 1)                  # nodes 1..6; quads (1,2,5,4), (2,3,6,5)
    nodes[4] = (0.45, 0.45, 0.0)                     # node 5 pulled inside quad 1: a dart
    els = [(3, 1, 1, q) for q in quads] + [(1, 2, 2, e) for e in left]
    path = msh22(tmp_path / "dart.msh", nodes, els, [(2, 1, "solid"), (1, 2, "left")])
    mesh = read(path)
    from solver.model.elements import FAMILIES, quadrature
    X = mesh.points[mesh.group("solid").cells["quad4"][:1]]
    assert (quadrature(FAMILIES["quad4"], X)[2] > 0).all()    # the Gauss points see nothing
    with pytest.raises(SceneError, match=r"model.body: group 'solid': gmsh element 1 \(quad4\) "
                                         r"non-convex or inverted \(at its corner node 2"):
        total_mass(mesh)
    scene = tmp_path / "s.yaml"
    scene.write_text(SCENE_2D.format(mesh=path, out=tmp_path / "s.h5"))
    line = refused(scene, [], tmp_path)
    assert "gmsh element 1 (quad4) non-convex" in line and "group 'solid'" in line


def test_dart_hex_is_refused():
    from solver.model.elements import FAMILIES, BadElement, quadrature, lumped_mass
    X = np.array(HEX, dtype=float)
    X[6] = (1.2, 1.2, 1.2)                            # corner 6 pushed inside
    assert (quadrature(FAMILIES["hex8"], X[None])[2] > 0).all()
    with pytest.raises(BadElement, match="corner node 6"):
        lumped_mass(FAMILIES["hex8"], X[None], Elastic(1e9, 0.3, 1e3))
    ok = np.array(HEX, dtype=float)[None]
    assert lumped_mass(FAMILIES["hex8"], ok, Elastic(1e9, 0.3, 1e3)).sum() == \
        pytest.approx(1e3 * 2 * 2 * (3 + 2.5 + 1.5 + 1) / 4, rel=1e-12)


CLOCKWISE = """lc = 0.5;
Point(1) = {0, 0, 0, lc}; Point(2) = {3, 0, 0, lc}; Point(3) = {3, 1, 0, lc};
Point(4) = {0, 1, 0, lc};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {LOOP}; Plane Surface(1) = {1};
RECOMBINE
Physical Surface("solid") = {1}; Physical Curve("left") = {4};
"""


@pytest.mark.parametrize("recombine", ["", "Recombine Surface {1};"])
def test_clockwise_surface_is_reoriented(tmp_path, recombine):
    meshes = {}
    for name, loop in (("ccw", "1, 2, 3, 4"), ("cw", "-4, -3, -2, -1")):
        (tmp_path / f"{name}.geo").write_text(CLOCKWISE.replace("LOOP", loop)
                                              .replace("RECOMBINE", recombine))
        meshes[name] = read(str(tmp_path / f"{name}.geo"))
    fam = "quad4" if recombine else "tri3"
    assert meshes["ccw"].notes == ()
    note, = meshes["cw"].notes
    assert "surface 1" in note and "negative orientation" in note and "reoriented" in note
    assert total_mass(meshes["cw"]) == pytest.approx(STEEL.rho * 3.0, rel=1e-12)
    from solver.model.elements import FAMILIES, volumes
    v = volumes(FAMILIES[fam], meshes["cw"].points[meshes["cw"].group("solid").cells[fam]])
    assert (v > 0).all() and v.sum() == pytest.approx(3.0, rel=1e-12)


def test_only_the_clockwise_entity_is_reoriented(tmp_path):
    """Two surfaces (gmsh entities 1 and 2) of one body: the clockwise one is
    turned, the other kept as it is; 2D and 3D alike."""
    nodes, quads, left = grid()
    els = [(3, 1, 1 if k < 3 else 2, q if k < 3 else q[::-1]) for k, q in enumerate(quads)]
    mesh = read(msh22(tmp_path / "m.msh", nodes, els + [(1, 2, 3, e) for e in left],
                      [(2, 1, "solid"), (1, 2, "left")]))
    note, = mesh.notes
    assert "surface 2 (3 quad4 cells) has negative orientation" in note
    conn = mesh.group("solid").cells["quad4"]
    xy = np.array(nodes)[:, :2]
    assert np.array_equal(mesh.points[conn[:3]], xy[np.array(quads[:3]) - 1])   # as they were
    turned = np.roll(np.array(quads[3:]) - 1, 1, axis=1)    # (d, c, b, a) read as (d, a, b, c)
    assert np.array_equal(mesh.points[conn[3:]], xy[turned])
    assert total_mass(mesh) == pytest.approx(STEEL.rho * 6.0, rel=1e-12)
    mirrored = [HEX[i] for i in (0, 3, 2, 1, 4, 7, 6, 5)]                 # a left-handed hex
    mesh = read(msh22(tmp_path / "h.msh", mirrored, [(5, 1, 7, tuple(range(1, 9)))],
                      [(3, 1, "solid")]))
    assert "volume 7 (1 hex8 cells) has negative orientation" in mesh.notes[0]
    solid = Elastic(1e9, 0.3, 1e3)
    (_, _, _, me), = group_matrices(mesh, "solid", solid)
    assert me.sum() == pytest.approx(8000.0, rel=1e-12)


def test_one_clockwise_cell_among_others_is_refused(tmp_path):
    nodes, quads, left = grid()
    quads[4] = quads[4][::-1]                         # element 5 alone runs clockwise
    els = [(3, 1, 1, q) for q in quads] + [(1, 2, 2, e) for e in left]
    mesh = read(msh22(tmp_path / "m.msh", nodes, els, [(2, 1, "solid"), (1, 2, "left")]))
    assert mesh.notes == ()
    with pytest.raises(SceneError, match=r"group 'solid': gmsh element 5 \(quad4\) inverted"):
        total_mass(mesh)


# -- 4. non-finite coordinates ------------------------------------------------------------------

@pytest.mark.parametrize("bad", ["nan", "inf"])
def test_non_finite_node_is_refused_naming_file_and_node(tmp_path, bad):
    nodes, quads, left = grid()
    nodes[6] = (2.0, float(bad), 0.0)
    path = msh22(tmp_path / "nan.msh", nodes, [(3, 1, 1, q) for q in quads] +
                 [(1, 2, 2, e) for e in left], [(2, 1, "solid"), (1, 2, "left")])
    with pytest.raises(SceneError, match=rf"{path}: node 7 has non-finite coordinates"):
        read(path)


def test_non_finite_node_exits_2_on_the_command_line(tmp_path):
    nodes, quads, left = grid()
    nodes[6] = (2.0, float("nan"), 0.0)
    path = msh22(tmp_path / "nan.msh", nodes, [(3, 1, 1, q) for q in quads] +
                 [(1, 2, 2, e) for e in left], [(2, 1, "solid"), (1, 2, "left")])
    scene = tmp_path / "s.yaml"
    scene.write_text(SCENE_2D.format(mesh=path, out=tmp_path / "s.h5"))
    line = refused(scene, [], tmp_path)
    assert line == f"error: {scene}: model.mesh: {path}: node 7 has non-finite coordinates " \
                   "[2.0, nan, 0.0] (1 such nodes)"


# -- 5. element types the kernels lack ------------------------------------------------------

@pytest.mark.parametrize("geo, words", [
    ("Mesh.ElementOrder = 2;", "second-order tri6 elements are not supported"),
    ("Mesh.ElementOrder = 2; Mesh.SecondOrderIncomplete = 1; Recombine Surface {1};",
     "second-order quad8 elements are not supported"),
    ("Mesh.ElementOrder = 2; Recombine Surface {1};", "second-order quad9 elements are not"),
    ("Mesh.ElementOrder = 3;", "third-order tri10 elements are not supported")])
def test_higher_order_surface_is_refused_in_words(tmp_path, geo, words):
    (tmp_path / "o.geo").write_text(CLOCKWISE.replace("LOOP", "1, 2, 3, 4")
                                    .replace("RECOMBINE", geo))
    with pytest.raises(SceneError) as err:
        read(str(tmp_path / "o.geo"))
    assert str(tmp_path / "o.geo") in str(err.value) and words in str(err.value)
    assert "supported: hex8, line2, point, quad4, tet4, tri3" in str(err.value)


def test_tet10_and_prism_are_refused_in_words(tmp_path):
    box = ("SetFactory(\"OpenCASCADE\"); Box(1) = {0, 0, 0, 1, 1, 1}; "
           "Physical Volume(\"solid\") = {1}; Mesh.MeshSizeMax = 0.5; ")
    (tmp_path / "t.geo").write_text(box + "Mesh.ElementOrder = 2;\n")
    with pytest.raises(SceneError, match="second-order tet10 elements are not supported"):
        read(str(tmp_path / "t.geo"))
    prism = ("Point(1) = {0, 0, 0}; Point(2) = {1, 0, 0}; Point(3) = {0, 1, 0}; "
             "Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 1}; Curve Loop(1) = {1, 2, 3}; "
             "Plane Surface(1) = {1}; v[] = Extrude {0, 0, 1} {Surface{1}; Layers{1}; Recombine;}; "
             "Physical Volume(\"solid\") = {v[1]};\n")
    (tmp_path / "p.geo").write_text(prism)
    with pytest.raises(SceneError, match=r"p.geo: group 'solid': prism6 elements are not "
                                         r"supported \(gmsh type 6\)"):
        read(str(tmp_path / "p.geo"))


# -- 6. network files that are not HDF5 ----------------------------------------------------

def _network_scene(tmp_path, path):
    raw = raw_scene("six_dof")
    raw["model"] = {"kind": "network", "file": str(path)}
    return write_scene(tmp_path / "net.yaml", raw)


@pytest.mark.parametrize("name, content", [("net.h5", "not hdf5\n"), ("net.npz", "text\n"),
                                           ("net.h5", ""), ("net.hdf5", "\x89HDF")])
def test_network_file_that_is_not_hdf5_is_named(tmp_path, name, content):
    path = tmp_path / name
    path.write_text(content)
    scene = _network_scene(tmp_path, path)
    line = refused(scene, [], tmp_path)
    kind = "an NPZ archive" if name.endswith(".npz") else "an HDF5 file"
    assert line.startswith(f"error: {scene}: model.file: {path}: not {kind} ("), line


def test_network_file_of_one_npy_array_is_named(tmp_path):
    path = tmp_path / "net.npy"
    np.save(path, np.ones(3))
    scene = _network_scene(tmp_path, path)
    line = refused(scene, [], tmp_path)
    assert line.startswith(f"error: {scene}: model.file: {path}: one .npy array, not an NPZ "
                           "archive"), line


# -- 7. load keys a load kind would ignore ------------------------------------------------------

@pytest.mark.parametrize("scene, sets, key, words", [
    ("wave_bar_3d", ["loads.0.component=4"], "loads[0].component", "component 4 out of range"),
    ("wave_bar_3d", ["loads.0.component=1"], "loads[0].component", "not both"),
    ("wave_bar_3d", ["loads.0.component=4", "loads.0.direction=null"], "loads[0].component",
     "component 4 out of range: a traction on group 'left' has 3 components"),
    ("wave_bar_fem", ["loads.0.component=2", "loads.0.direction=null"], "loads[0].component",
     "has 2 components"),
    ("six_dof", ["loads.0.direction=[1.0]"], "loads[0].direction", "is for group loads"),
    ("six_dof", ["loads.0.start=1.0"], "loads[0].start", "not used by a sine load"),
    ("six_dof", ["loads.0.component=1"], "loads[0].component", "out of range"),
    ("six_dof", ["loads.0.kind=tabulated", "loads.0.omega=null", "loads.0.amplitude=2.0",
                 "loads.0.table=[[0, 0], [1, 1]]"], "loads[0].amplitude", "tabulated"),
    ("wave_bar_3d", ["loads.0.group=solid"], "loads[0].group",
     "group 'solid' (dim 3, hex8) has no edges or faces to carry a traction")])
def test_load_keys_that_would_be_ignored_are_refused(tmp_path, scene, sets, key, words):
    line = refused(ROOT / f"configs/{scene}.yaml", sets, tmp_path)
    assert line.startswith(f"error: {ROOT}/configs/{scene}.yaml: {key}: "), line
    assert words is None or words in line, line


def test_group_load_component_sets_the_traction_axis():
    from solver.model.binding import from_dict
    from solver.model import boundary, data
    raw = raw_scene("wave_bar_fem")
    raw["loads"][0].pop("direction")
    raw["loads"][0]["component"] = 1
    scene = from_dict(raw)
    assert scene.loads[0].direction == (0.0, 1.0) and scene.loads[0].component is None
    loads = boundary.load_list(scene, data.read(scene.model), 2, 2)
    assert loads and all(pl.dof % 2 == 1 for pl in loads)
    assert sum(pl.scale for pl in loads) == pytest.approx(0.0024, rel=1e-12)   # the edge length
