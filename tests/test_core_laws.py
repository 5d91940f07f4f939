"""Element families and contact laws as declared objects (solver/model/elements.py,
solver/laws.py): every family declares every fact and the facts agree with
gmsh's and meshio's own tables; each contact law's force is the derivative of
its energy and its step-bound stiffness bounds its tangent; a law registered
here is accepted by the scene key and used by the DEM force and step bound;
no module outside the registries compares a family or law name."""
from __future__ import annotations

import ast
import math
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np
import pytest

from conftest import built, raw_scene
from solver.laws import BOND_GEOMETRIES, CONTACT_LAWS, ContactLaw, ContactSettings
from solver.model.elements import CELLS, FAMILIES, Family, Families
from solver.model.shell_model import SHELL3

ROOT = Path(__file__).resolve().parents[1]
DECLARED = [*CELLS.values(), SHELL3]
MEASURE = {(2, True): 0.5, (2, False): 4.0, (3, True): 1 / 6, (3, False): 8.0}


def reference_nodes(family: Family) -> np.ndarray:
    """The reference cell's node coordinates (gmsh order)."""
    if family.corners is not None:
        return family.corners
    return np.vstack([np.zeros(family.dim), np.eye(family.dim)])


@pytest.mark.parametrize("family", DECLARED, ids=lambda f: f.name)
def test_every_family_declares_every_fact(family):
    import gmsh
    from meshio.xdmf.common import meshio_to_xdmf_type
    assert family.basis is not None and family.mesh_cells in CELLS
    assert family.points.shape == (len(family.weights), family.dim)
    N, dN = family.shape(family.points)
    assert N.shape == (len(family.weights), family.n_nodes)
    assert np.allclose(N.sum(axis=1), 1.0, rtol=0, atol=1e-14)      # partition of unity
    assert np.allclose(dN.sum(axis=1), 0.0, rtol=0, atol=1e-14)
    assert meshio_to_xdmf_type[family.meshio][0] == family.xdmf
    gmsh.initialize(interruptible=False)
    try:
        _, dim, order, n_nodes, _, _ = gmsh.model.mesh.getElementProperties(family.gmsh)
    finally:
        gmsh.finalize()
    assert (dim, order, n_nodes) == (family.dim, min(family.dim, 1), family.n_nodes)  # linear
    assert len(family.centre) == family.dim
    if family.dim == 0:
        return
    assert family.facet in CELLS and CELLS[family.facet].dim == family.dim - 1
    if family.mirror is None:                 # only the families of no body
        assert family.dim < 2 and not family.body
        return
    # a body family: quadrature weights sum to the reference measure, and the
    # centre is the reference nodes' mean
    assert family.lumping in ("row_sum", "row_sum_rotary")
    assert (family.lumping == "row_sum_rotary") == family.rotations
    assert abs(family.weights.sum() - MEASURE[family.dim, family.simplex]) < 1e-14
    assert np.allclose(reference_nodes(family).mean(axis=0), family.centre, rtol=0, atol=1e-15)
    assert (family.corners is None) == family.simplex


@pytest.mark.parametrize("family", list(FAMILIES.values()), ids=lambda f: f.name)
def test_families_round_trip_through_gmsh_meshio_and_their_facets(family):
    assert FAMILIES[family.name] is CELLS[family.name] is family
    assert CELLS.by_gmsh[family.gmsh] is family and CELLS.by_meshio[family.meshio] is family
    chain, f = [family.name], family
    while f.facet is not None:                # tet4 -> tri3 -> line2 -> point
        f = CELLS[f.facet]
        chain.append(f.name)
    assert len(chain) == family.dim + 1 and CELLS[chain[-1]].dim == 0
    # the mirror order reverses the orientation: the Jacobian determinant's sign
    X = reference_nodes(family)
    _, dN = family.shape(np.array([family.centre]))
    det = np.linalg.det(dN[0].T @ X)
    det_m = np.linalg.det(dN[0].T @ X[list(family.mirror)])
    assert det > 0 and abs(det_m + det) < 1e-12 * det
    assert sorted(family.mirror) == list(range(family.n_nodes))


def test_the_facet_families_are_the_traction_cells_and_registering_twice_is_refused():
    assert FAMILIES.facets() == ("line2", "tri3", "quad4")
    assert sorted(FAMILIES) == ["hex8", "quad4", "tet4", "tri3"]
    assert not (set(CELLS) - set(FAMILIES)) - {"point", "line2"}
    registry = Families()
    registry.register(FAMILIES["tri3"])
    with pytest.raises(ValueError, match="gmsh 2 is already tri3's"):
        registry.register(Family("tri3b", 2, 3, FAMILIES["tri3"].points,
                                 FAMILIES["tri3"].weights, gmsh=2))


RADIUS = 1e-4


@pytest.mark.parametrize("name", ["linear", "hertz"])
def test_a_contact_laws_force_is_the_derivative_of_its_energy_and_its_bound_holds(name):
    """f = dE/dd and tangent = df/dd (central differences, relative 1e-6); the
    step-bound stiffness bounds the tangent over 0 < d <= bound_overlap x r
    and is reached at the range's end (hertz: 0.1 r; linear: everywhere)."""
    law = CONTACT_LAWS[name](2.5e7)
    top = min(law.bound_overlap, 1.0) * RADIUS
    d = np.linspace(0.02, 1.0, 50) * top
    h = 1e-6 * top
    f, k, energy = law.evaluate(d)
    assert np.allclose((law.energy(d + h) - law.energy(d - h)) / (2 * h), f, rtol=1e-6, atol=0)
    assert np.allclose((law.force(d + h) - law.force(d - h)) / (2 * h), k, rtol=1e-6, atol=0)
    assert law.energy(np.zeros(1))[0] == 0.0 and (f > 0).all() and (energy > 0).all()
    bound = law.bound(RADIUS)
    assert (k <= bound * (1 + 1e-12)).all()
    assert abs(k[-1] / bound - 1) < 1e-12
    if math.isfinite(law.bound_overlap):     # beyond the range the tangent exceeds it
        assert law.tangent(np.array([2 * top]))[0] > 1.1 * bound


@dataclass(frozen=True)
class Cubic(ContactLaw):
    """A toy law registered by the test: f = k d^3, E = k d^4 / 4."""

    name: ClassVar[str] = "cubic_toy"
    unit: ClassVar[str] = "N/m^3"
    bound_overlap: ClassVar[float] = 0.1

    def evaluate(self, overlap):
        k = self.stiffness
        return k * overlap ** 3, 3 * k * overlap ** 2, 0.25 * k * overlap ** 4

    def bound(self, radius):
        return 3 * self.stiffness * (self.bound_overlap * radius) ** 2


@pytest.fixture
def cubic(monkeypatch):
    monkeypatch.setitem(CONTACT_LAWS, Cubic.name, Cubic)
    return Cubic


def contact_scene(law=None, stiffness=None):
    """wave_bar_transition with nonlinear bonds and (given a law) contact."""
    raw = raw_scene("wave_bar_transition")
    raw["model"]["lattice"]["geometry"] = "nonlinear"
    if law is not None:
        raw["model"]["lattice"]["contact"] = {"stiffness": stiffness, "law": law}
    return raw


def test_a_law_registered_elsewhere_is_a_scene_value_and_drives_the_dem(cubic, tmp_path):
    """The scene key accepts the toy law; the dem partition's contact evaluates
    it (two particles at overlap d: force k d^3 along the line of centres) and
    the step bound adds 2 z k_bound / m_min to the bonds' lambda_max."""
    from solver.partitions.contact import Contact, coordination
    from solver.scene import from_dict
    from solver.tools.cli import keys_markdown
    k = 1e16
    assert from_dict(contact_scene("cubic_toy", k)).model.lattice.contact.law == "cubic_toy"
    assert "| `model.lattice.contact.law` | linear \\| hertz \\| cubic_toy | 'linear' |" in \
        keys_markdown()                                   # the keys list it while registered
    plain = built(contact_scene(), tmp_path)
    toy = built(contact_scene("cubic_toy", k), tmp_path)
    dem = next(p for p in toy.parts if p.method == "dem")
    settings = dem.force_model.contact
    assert settings.law == Cubic(k) and dem.force.contact.law is settings.law
    w0 = plain.scheme.freqs["dem"][0].omega_max
    w1 = toy.scheme.freqs["dem"][0].omega_max
    m_min = dem.mass[:dem.n_own].min()
    bound = 3 * k * (0.1 * settings.radius) ** 2
    assert abs(w1 ** 2 - w0 ** 2 - 2 * coordination(2) * bound / m_min) < 1e-9 * w1 ** 2
    assert w1 ** 2 - w0 ** 2 > 1e-3 * w0 ** 2                      # the bound counts
    plain.destroy()
    toy.destroy()
    r, d, unit = settings.radius, 1e-6, np.array([0.6, 0.8])
    c = Contact(np.arange(2), settings, np.zeros(0, np.int64), np.zeros(0, np.int64),
                np.array([1e-6, 1e-6]))
    out = np.zeros((2, 2))
    c.forces(np.array([[0.0, 0.0], (2 * r - d) * unit]), np.zeros(0, bool), out, 2)
    assert np.allclose(out[1], k * d ** 3 * unit, rtol=1e-9)
    assert abs(c.energy / (0.25 * k * d ** 4) - 1) < 1e-9


def test_an_unregistered_law_or_geometry_is_refused_naming_the_choices():
    from solver.errors import SceneError
    from solver.scene import from_dict
    with pytest.raises(SceneError, match=r"model.lattice.contact.law: 'cubic_toy' is not one "
                                         r"of linear, hertz"):
        from_dict(contact_scene("cubic_toy", 1e15))
    raw = raw_scene("wave_bar_transition")
    raw["model"]["lattice"]["geometry"] = "curved"
    with pytest.raises(SceneError, match="model.lattice.geometry: 'curved' is not one of "
                                         "linear, nonlinear"):
        from_dict(raw)
    assert [(g, BOND_GEOMETRIES[g].current) for g in BOND_GEOMETRIES] == \
        [("linear", False), ("nonlinear", True)]


def test_the_contact_settings_are_keyword_fields_holding_the_law():
    from solver.model.continuum import contact_of
    from solver.scene import from_dict
    lat = from_dict(contact_scene("hertz", 3e9)).model.lattice
    s = contact_of(lat)
    assert s == ContactSettings(law=CONTACT_LAWS["hertz"](3e9), radius=0.5 * lat.spacing,
                                skin=0.3 * (0.5 * lat.spacing), damping_ratio=0.0, friction=0.0,
                                tangential_damping_ratio=0.5)


NAMES = {*CELLS, SHELL3.name, *(f.meshio for f in CELLS.values())}
LAW_NAMES = {*CONTACT_LAWS, *BOND_GEOMETRIES}
REGISTRIES = {"solver/model/elements.py", "solver/laws.py"}


def _strings(node) -> set:
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return {node.value}
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        return set().union(*(_strings(e) for e in node.elts))
    return set()


def _about_laws(node) -> bool:
    """Whether an expression names a law or bond geometry (law, geometry, bond_geometry)."""
    words = [n.id if isinstance(n, ast.Name) else n.attr if isinstance(n, ast.Attribute) else
             n.value if isinstance(n, ast.Constant) and isinstance(n.value, str) else ""
             for n in ast.walk(node)]
    return any("law" in w or "geometry" in w for w in words)


def name_branches(source: str) -> list:
    """(line, code) of the comparisons with, tables keyed by and look-ups of a
    family name, and the comparisons of a law or geometry with its name."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Compare):
            sides = [node.left, *node.comparators]
            names = set().union(*map(_strings, sides))
            hit = names & NAMES or (names & LAW_NAMES and any(map(_about_laws, sides)))
        elif isinstance(node, ast.Dict):
            hit = set().union(*(_strings(k) for k in node.keys if k is not None)) & NAMES
        elif isinstance(node, ast.Subscript):
            hit = _strings(node.slice) & NAMES
        else:
            continue
        if hit:
            found.append((node.lineno, ast.unparse(node)[:80]))
    return found


def test_no_module_outside_the_registries_branches_on_a_family_or_law_name():
    found = [f"{path.relative_to(ROOT)}:{line}: {code}"
             for path in sorted((ROOT / "solver").rglob("*.py"))
             if path.relative_to(ROOT).as_posix() not in REGISTRIES
             for line, code in name_branches(path.read_text())]
    assert found == []


def test_the_ast_check_sees_a_name_branch():
    """The check is not blind: it finds each kind of branch it forbids, and
    leaves a 'linear' that is no law alone."""
    code = ('if fam == "hex8": pass\nif law == "hertz": pass\nt = {"quad": 1}\n'
            'x = cells["tri3"]\nif motion == "linear": pass\n'
            'if getattr(m, "bond_geometry", "linear") != "linear": pass\n')
    assert [line for line, _ in name_branches(code)] == [1, 2, 3, 4, 6]
